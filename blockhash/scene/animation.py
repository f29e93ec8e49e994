"""Animated scenes: keyframes for the camera, the lights and the objects' rigid placement, and
the scene of any frame between them.

A scene file's ``[animation]`` table (every key listed; any other is an error)::

    [animation]
    frames = 48                     # required, frames 0 .. frames - 1, 1 .. 100000
    fps = 24                        # default 24, the video's frames per second, > 0
    [animation.orbit]               # optional shorthand: the camera circles its target
    turns = 1.0                     #   required, turns over the frames (negative: clockwise
                                    #   seen from above the axis); frame f is at f / frames
    axis = [0.0, 1.0, 0.0]          #   default the camera's up; the turn's axis through the
                                    #   target

    [[animation.camera]]            # camera keys (not with orbit); each a frame and any of
    frame = 0                       #   eye, target, up, fov_y_deg
    eye = [0.0, 1.9, 1.6]

    [[animation.lights]]            # light keys: the light's index in the scene's lights
    light = 0                       #   ([[lights]] in file order, then the area lights), a
    frame = 0                       #   frame and any of position, direction (point and spot
    position = [-2.0, 1.0, 0.0]     #   lights; direction for directional lights too) and
                                    #   power (point and spot lights)

    [[animation.objects]]           # object keys: an object's name, a frame and its rigid
    object = "ring"                 #   motion from where the scene file places it:
    frame = 0                       #   rotate_deg (about x, then y, then z, about the
    rotate_deg = [0.0, 0.0, 0.0]    #   ``pivot``, default the object's box centre) and
    translate = [0.0, 0.0, 0.0]     #   translate; rigid only (a scale is refused)

Between keys every value is interpolated linearly (a direction linearly then normalised, a
rotation by its angles); before a target's first key and after its last the value holds.  A
value a target's keys never give stays the scene file's.  Keys of one target are in
increasing frame order and within the frames; a key for an unknown light or object, a
property a light of its kind does not have, or a scale is an error naming the key and the way
out.  An area light cannot be animated (its object can be: the light moves with it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from blockhash.errors import InputError
from blockhash.scene.values import FieldError, got, integer, number, vector

CAMERA_KEYS = ("eye", "target", "up", "fov_y_deg")
LIGHT_KEYS = ("position", "direction", "power")
OBJECT_KEYS = ("rotate_deg", "translate", "pivot")


@dataclass(frozen=True)
class Key:
    """One keyframe: ``frame`` and the ``values`` it sets (name -> float or (3,) array)."""

    frame: int
    values: dict


@dataclass(frozen=True)
class Animation:
    """``frames`` frames at ``fps``; ``camera`` keys, ``lights`` keys by light index,
    ``objects`` keys by object name, ``orbit`` (turns, axis or None) the camera's circle."""

    frames: int
    fps: float = 24.0
    camera: tuple = ()
    lights: dict = field(default_factory=dict)
    objects: dict = field(default_factory=dict)
    orbit: tuple | None = None

    @property
    def moves_photons(self) -> bool:
        """A light or an object moves: each frame's photons are traced again (from the same
        streams); with the camera alone moving, every frame gathers the same photons."""
        return bool(self.lights) or bool(self.objects)

    def scene_at(self, scene, frame: int):
        """The scene of ``frame`` (0 .. frames - 1)."""
        from blockhash.scene.lights import AreaLight

        frame = integer(frame, "frame", lo=0, hi=self.frames - 1,
                        hint=f"the animation has frames 0 .. {self.frames - 1}")

        cam = scene.camera
        if self.orbit is not None:
            cam = _orbit(cam, self.orbit, frame / self.frames)
        elif self.camera:
            cam = replace(cam, **_at(self.camera, frame))
        lights = list(scene.lights)
        for i, keys in self.lights.items():
            lights[i] = replace(lights[i], **_at(keys, frame))
        objects = list(scene.objects)
        moved = {}
        for name, keys in self.objects.items():
            j = next(k for k, o in enumerate(objects) if o.name == name)
            values = _at(keys, frame)
            mesh = _rigid(objects[j].mesh, values)
            moved[name] = mesh
            objects[j] = replace(objects[j], mesh=mesh)
        lights = [replace(li, mesh=moved[li.object]) if isinstance(li, AreaLight)
                  and li.object in moved else li for li in lights]
        return replace(scene, camera=cam, lights=tuple(lights), objects=tuple(objects))


def _at(keys, frame: int) -> dict:
    """The values of ``keys`` at ``frame`` (module docstring's interpolation)."""
    out = {}
    names = {n for k in keys for n in k.values}
    for name in names:
        have = [k for k in keys if name in k.values]
        if frame <= have[0].frame:
            v = have[0].values[name]
        elif frame >= have[-1].frame:
            v = have[-1].values[name]
        else:
            b = next(i for i, k in enumerate(have) if k.frame >= frame)
            a = have[b - 1]
            t = (frame - a.frame) / (have[b].frame - a.frame)
            v = (1.0 - t) * np.asarray(a.values[name]) + t * np.asarray(have[b].values[name])
            if name in ("direction", "up"):
                v = v / max(float(np.linalg.norm(v)), 1e-300)
        out[name] = v if np.ndim(v) == 0 else np.asarray(v, dtype=np.float64)
    if "fov_y_deg" in out:
        out["fov_y_deg"] = float(out["fov_y_deg"])
    return out


def _orbit(camera, orbit, fraction: float):
    turns, axis = orbit
    axis = np.asarray(camera.up if axis is None else axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    angle = 2.0 * math.pi * turns * fraction
    eye = _rotate(camera.eye - camera.target, axis, angle) + camera.target
    return replace(camera, eye=eye)


def _rotate(v, axis, angle):
    """``v`` turned by ``angle`` radians about unit ``axis`` (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * float(axis @ v) * (1.0 - c)


def _rigid(mesh, values: dict):
    """``mesh`` turned by ``rotate_deg`` about ``pivot`` (default its box centre), then moved
    by ``translate``: positions and normals (a rigid motion keeps them unit)."""
    from blockhash.scene.meshes import rotation, with_normals

    pivot = np.asarray(values.get("pivot", 0.5 * (mesh.bounds[0] + mesh.bounds[1])))
    r = rotation(values.get("rotate_deg", np.zeros(3)))
    t = np.asarray(values.get("translate", np.zeros(3)))
    v = (np.asarray(mesh.vertices) - pivot) @ r.T + pivot + t
    return with_normals(v, mesh.faces, np.asarray(mesh.vertex_normals) @ r.T)


# --------------------------------------------------------------------------- parsing

def parse_animation(t, scene) -> Animation:
    """The ``[animation]`` table ``t`` of ``scene``'s file (module docstring); a
    :class:`~blockhash.scene.values.FieldError` naming the key on bad input."""
    if not isinstance(t, dict):
        raise FieldError("animation", f"expected a table [animation]; got {got(t)}")
    _only(t, "animation", ("frames",), ("fps", "orbit", "camera", "lights", "objects"))
    frames = integer(t["frames"], "animation.frames", lo=1, hi=100_000)
    fps = number(t.get("fps", 24.0), "animation.fps", lo=0.0, lo_open=True, hi=1000.0)
    orbit = None
    if "orbit" in t:
        if "camera" in t:
            raise FieldError("animation.orbit", "an orbit and [[animation.camera]] keys both move "
                             "the camera; keep one")
        o = t["orbit"]
        if not isinstance(o, dict):
            raise FieldError("animation.orbit", f"expected a table; got {got(o)}")
        _only(o, "animation.orbit", ("turns",), ("axis",))
        axis = None
        if "axis" in o:
            axis = vector(o["axis"], "animation.orbit.axis", unit="a direction")
            if not np.linalg.norm(axis) > 0:
                raise FieldError("animation.orbit.axis", "expected a non-zero axis; e.g. [0, 1, 0]")
        orbit = (number(o["turns"], "animation.orbit.turns"), axis)
    camera = _keys(t.get("camera", []), "animation.camera", frames, CAMERA_KEYS, None)
    lights: dict = {}
    for i, k in enumerate(_tables(t.get("lights", []), "animation.lights")):
        key = f"animation.lights[{i}]"
        if "light" not in k:
            raise FieldError(f"{key}.light", "missing required key: the light's index in the "
                             "scene's lights (0 for the first [[lights]])")
        li = integer(k["light"], f"{key}.light", lo=0)
        if li >= len(scene.lights):
            raise FieldError(f"{key}.light", f"light {li}: the scene has {len(scene.lights)} "
                             f"light(s), 0 .. {len(scene.lights) - 1}; give one of those")
        light = scene.lights[li]
        allowed = tuple(n for n in LIGHT_KEYS if hasattr(light, n))
        if hasattr(light, "radiance"):
            raise FieldError(f"{key}.light", f"light {li} is an area light on object "
                             f"{light.object!r}: animate that object instead")
        lights.setdefault(li, []).append((i, k, allowed))
    lights = {li: _keys([k for _, k, _ in ks], "animation.lights", frames, ks[0][2], "light",
                        first=ks[0][0]) for li, ks in lights.items()}
    objects: dict = {}
    names = {o.name for o in scene.objects}
    for i, k in enumerate(_tables(t.get("objects", []), "animation.objects")):
        key = f"animation.objects[{i}]"
        if "object" not in k:
            raise FieldError(f"{key}.object", "missing required key: the object's name")
        name = k["object"]
        if name not in names:
            raise FieldError(f"{key}.object", f"unknown object {name!r}; the scene's objects: "
                             f"{', '.join(sorted(names))}")
        if "scale" in k:
            raise FieldError(f"{key}.scale", "an object's motion is rigid (rotate_deg, "
                             "translate); a scale would change its shape: scale it in its "
                             "[[objects]] table instead")
        objects.setdefault(name, []).append(k)
    objects = {n: _keys(ks, "animation.objects", frames, OBJECT_KEYS, "object")
               for n, ks in objects.items()}
    return Animation(frames=frames, fps=fps, camera=camera, lights=lights, objects=objects,
                     orbit=orbit)


def _tables(value, key: str) -> list:
    if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
        raise FieldError(key, f"expected an array of tables [[{key}]]; got {got(value)}")
    return value


def _only(t: dict, key: str, required, optional) -> None:
    for name in required:
        if name not in t:
            raise FieldError(f"{key}.{name}", "missing required key")
    for name in t:
        if name not in required + optional:
            raise FieldError(f"{key}.{name}", "unknown key; allowed keys here: "
                             + ", ".join(required + optional))


def _keys(tables, key: str, frames: int, allowed, owner, first: int = 0) -> tuple:
    """Keys from ``tables``: each a frame within the frames and values of ``allowed``, in
    increasing frame order (``owner``: the key naming the target, skipped)."""
    out = []
    for i, t in enumerate(_tables(tables, key)):
        k = f"{key}[{first + i}]"
        if "frame" not in t:
            raise FieldError(f"{k}.frame", "missing required key: the key's frame")
        f = integer(t["frame"], f"{k}.frame", lo=0, hi=frames - 1,
                    hint=f"a key's frame lies in 0 .. {frames - 1} (animation.frames = {frames})")
        values = {}
        for name, v in t.items():
            if name in ("frame", owner):
                continue
            if name not in allowed:
                raise FieldError(f"{k}.{name}", "not animated here; allowed: "
                                 + ", ".join(allowed))
            values[name] = (number(v, f"{k}.{name}") if name == "fov_y_deg"
                            else vector(v, f"{k}.{name}") if name != "power"
                            else _power(v, f"{k}.{name}"))
        if not values:
            raise FieldError(k, f"the key sets nothing; give any of {', '.join(allowed)}")
        if out and f <= out[-1].frame:
            raise FieldError(f"{k}.frame", f"frame {f} after a key at frame {out[-1].frame}: "
                             "keys of one target go in increasing frame order; reorder them")
        out.append(Key(f, values))
    return tuple(out)


def _power(v, key):
    from blockhash.scene.values import rgb

    return rgb(v, key, what="power in watts")


def check_animation(animation: Animation, scene) -> None:
    """Every frame's scene is valid (a key that makes a camera's up parallel to its view,
    say, is an error naming the frame)."""
    for f in sorted({0, animation.frames - 1, *(k.frame for k in animation.camera)}):
        try:
            animation.scene_at(scene, f)
        except InputError as exc:
            raise FieldError("animation", f"frame {f}: {exc}") from None
