"""Mitsuba 3's ``constant`` and ``envmap`` emitters (for :mod:`.importer`):
:func:`environment` and :func:`envmap`."""

from __future__ import annotations

import numpy as np
import trimesh

from blockhash.errors import InputError
from blockhash.scene.environment_light import EnvironmentLight
from blockhash.scene.meshes import with_normals
from blockhash.scene.model import AreaLight, PhongMaterial, SceneObject
from blockhash.scene.texture import read_image

#: How much larger than the box around the scene and the camera a constant environment's
#: emitting box is (:func:`environment`).
ENVIRONMENT_MARGIN = 1.5


def environment(r, el, objects, eye) -> tuple:
    """(object, AreaLight) of a ``constant`` emitter: a box around the scene and the camera
    (:data:`ENVIRONMENT_MARGIN` times larger) whose faces turn inward and emit its
    ``radiance``, reflecting nothing.  Radiance does not fall off with distance, so every ray
    that leaves the scene meets the box and sees that radiance, wherever it starts inside:
    exactly a constant environment, rendered as any area light (photons, direct light, the
    box seen directly, in mirrors and through glass)."""
    p = r.props(el, {"radiance": ("rgb", "spectrum", "float")}, emitter=True)
    points = np.concatenate([np.asarray(o.mesh.vertices, np.float64) for o in objects]
                            + [np.asarray(eye, np.float64)[None]])
    lo, hi = points.min(axis=0), points.max(axis=0)
    half = ENVIRONMENT_MARGIN * max(float((hi - lo).max()) / 2.0, 1e-6)
    box = trimesh.creation.box(extents=(2.0 * half,) * 3)
    box.unmerge_vertices()
    box.apply_translation((lo + hi) / 2.0)
    inward = np.asarray(box.faces)[:, ::-1]
    mesh = with_normals(box.vertices, inward, -np.repeat(box.face_normals, 3, axis=0))
    name = el.get("id") or "constant-environment"
    obj = r.build(el, SceneObject, name=name, mesh=mesh,
                  material=PhongMaterial(kd=0.0, ks=0.0, n=0.0, sided="one"))
    return obj, r.build(el, AreaLight, object=name, mesh=mesh,
                        radiance=np.broadcast_to(p.get("radiance", 1.0), (3,)))


def envmap(r, el) -> EnvironmentLight:
    """The :class:`EnvironmentLight` of an ``envmap`` emitter: its ``filename`` (found as a
    mesh file is, :meth:`resolve`) read by :func:`blockhash.scene.texture.read_image`, times ``scale``, turned by
    ``to_world``'s rotation.  ``mis_compensation`` changes only how Mitsuba samples the map,
    not the image: accepted without a word."""
    p = r.props(el, {"filename": ("string",), "scale": ("float",), "to_world": ("transform",),
                     "mis_compensation": ("boolean",)}, emitter=True)
    if "filename" not in p:
        r.fail(el, "an envmap needs its image: add <string name=\"filename\" value=\"sky.exr\"/>")
    path = r.resolve(el, p["filename"], "environment map")
    try:
        image = read_image(path)
    except InputError as exc:
        r.fail(el, str(exc))
    scale = float(p.get("scale", 1.0))
    if not scale > 0.0:
        r.fail(el, f"scale {scale:g}: an environment map's scale must be > 0")
    m = p.get("to_world", np.eye(4))[:3, :3]
    return r.build(el, EnvironmentLight, image=image * scale, to_world=m,
                   name=el.get("id") or path.name)
