"""The scene's lights: point and spot lights, area lights (an object that emits) and
directional lights (sunlight), frozen dataclasses that validate their own values (every error
an :class:`~blockhash.errors.InputError` naming the key path), and :func:`check_lights`, what
a :class:`blockhash.scene.model.Scene` checks of them against its objects."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import trimesh

from blockhash.scene.environment_light import EnvironmentLight
from blockhash.scene.values import FieldError as _FieldError
from blockhash.scene.values import check_mesh
from blockhash.scene.values import fmt as _fmt
from blockhash.scene.values import number as _number
from blockhash.scene.values import owned as _owned
from blockhash.scene.values import readonly as _readonly
from blockhash.scene.values import rgb as _rgb
from blockhash.scene.values import string as _string
from blockhash.scene.values import vector as _vector


def _power(value, key: str) -> np.ndarray:
    p = _rgb(value, key, what="power in watts")
    if not p.any():
        raise _FieldError(key, "the light emits nothing (power 0 in every channel); "
                          "expected watts > 0 in at least one channel")
    return p


@dataclass(frozen=True, eq=False)
class PointLight:
    """Isotropic point light: ``position`` (3,) metres, ``power`` (3,) watts RGB
    (total, over the whole sphere)."""

    position: np.ndarray
    power: np.ndarray

    def __post_init__(self):
        with _owned("PointLight"):
            object.__setattr__(self, "position", _vector(self.position, "position"))
            object.__setattr__(self, "power", _power(self.power, "power"))

    def __repr__(self) -> str:
        return f"PointLight(position={_fmt(self.position)}, power={_fmt(self.power)})"


def falloff_solid_angle(cone_deg: float, beam_deg: float) -> float:
    """The integral over directions of a spot's falloff (:meth:`SpotLight.falloff`): ``2 pi (1 -
    (sin c - sin b) / (c - b))`` for the cone's and the beam's half angles c and b, and the
    cone's solid angle ``2 pi (1 - cos c)`` when they are equal (the power over the peak
    intensity)."""
    c, b = math.radians(cone_deg), math.radians(beam_deg)
    if b >= c:
        return 2.0 * math.pi * (1.0 - math.cos(c))
    return 2.0 * math.pi * (1.0 - (math.sin(c) - math.sin(b)) / (c - b))


@dataclass(frozen=True, eq=False)
class SpotLight:
    """Spot light: ``position`` (3,) metres, ``direction`` (3,) unit axis,
    ``power`` (3,) watts RGB emitted into the cone of half angle ``cone_deg`` in (0, 90].
    Inside ``beam_deg`` (default ``cone_deg``: uniform in the whole cone) the intensity is
    its peak; from there to ``cone_deg`` it falls linearly in the angle to 0, as Mitsuba 3's
    ``spot`` (``beam_width``, ``cutoff_angle``): :meth:`falloff`."""

    position: np.ndarray
    direction: np.ndarray
    power: np.ndarray
    cone_deg: float
    beam_deg: float | None = None
    #: A texture projected across the cone (:class:`blockhash.scene.texture.Texture`, as
    #: Mitsuba's spot's ``texture``): the intensity toward a direction times the texture at
    #: ``(1/2 + x / (2 z tan cone), 1/2 + y / (2 z tan cone))``, (x, y, z) the direction in
    #: ``frame``'s axes (3 x 3, columns x, y and the cone's axis).  ``power`` stays the
    #: untextured cone's.
    texture: object = None
    frame: np.ndarray | None = None

    def __post_init__(self):
        with _owned("SpotLight"):
            if self.texture is not None:
                f = np.asarray(self.frame, dtype=np.float64) if self.frame is not None else None
                if f is None or f.shape != (3, 3) or not np.allclose(f.T @ f, np.eye(3), atol=1e-6):
                    raise _FieldError("frame", "a textured spot needs its frame: 3 x 3, "
                                      "orthonormal columns x, y and the cone's axis")
                object.__setattr__(self, "frame", _readonly(f))
            object.__setattr__(self, "position", _vector(self.position, "position"))
            d = _vector(self.direction, "direction", unit="a direction")
            length = float(np.linalg.norm(d))
            if length == 0.0:
                raise _FieldError("direction", "expected a non-zero direction for the cone's axis; "
                                  "got (0, 0, 0)")
            object.__setattr__(self, "direction", _readonly(d / length))
            object.__setattr__(self, "power", _power(self.power, "power"))
            object.__setattr__(self, "cone_deg", _number(
                self.cone_deg, "cone_deg", lo=0.0, hi=90.0, lo_open=True,
                hint="cone_deg is the half angle of the cone in degrees"))
            beam = self.cone_deg if self.beam_deg is None else self.beam_deg
            object.__setattr__(self, "beam_deg", _number(
                beam, "beam_deg", lo=0.0, hi=self.cone_deg, lo_open=True,
                hint="beam_deg is the half angle of full intensity, at most cone_deg"))

    @property
    def uniform(self) -> bool:
        """The intensity is the same in the whole cone (``beam_deg == cone_deg``)."""
        return self.beam_deg == self.cone_deg

    @property
    def solid_angle(self) -> float:
        """Steradians inside the cone, ``2 pi (1 - cos cone)``."""
        return 2.0 * math.pi * (1.0 - math.cos(math.radians(self.cone_deg)))

    @property
    def falloff_solid_angle(self) -> float:
        """The integral of :meth:`falloff` over directions (:func:`falloff_solid_angle`)."""
        return falloff_solid_angle(self.cone_deg, self.beam_deg)

    @property
    def peak_intensity(self) -> np.ndarray:
        """(3,) W/sr inside the beam: the power over :attr:`falloff_solid_angle`."""
        return np.asarray(self.power, dtype=np.float64) / self.falloff_solid_angle

    def falloff(self, cos_axis) -> np.ndarray:
        """The intensity toward directions at ``cos_axis`` to the axis over the peak: 1 inside
        the beam, ``(c - theta) / (c - b)`` between the beam and the cone, 0 outside."""
        cos_axis = np.asarray(cos_axis, dtype=np.float64)
        c, b = math.radians(self.cone_deg), math.radians(self.beam_deg)
        inside = cos_axis > math.cos(c)
        if self.uniform:
            return inside.astype(np.float64)
        theta = np.arccos(np.clip(cos_axis, -1.0, 1.0))
        ramp = np.where(theta <= b, 1.0, (c - theta) / (c - b))
        return np.where(inside, np.clip(ramp, 0.0, 1.0), 0.0)

    def texture_factor(self, dirs) -> np.ndarray:
        """(n, 3) the texture toward unit world directions ``dirs`` (n, 3) leaving the light
        (ones without a texture; zeros behind the light)."""
        dirs = np.asarray(dirs, dtype=np.float64)
        if self.texture is None:
            return np.ones((len(dirs), 3))
        local = dirs @ self.frame  # (x, y, z) in the frame's axes
        z = local[:, 2]
        scale = 0.5 / (np.where(z > 0.0, z, 1.0) * math.tan(math.radians(self.cone_deg)))
        uv = 0.5 + local[:, :2] * scale[:, None]
        return np.where((z > 0.0)[:, None], self.texture.value(uv), 0.0)

    def __repr__(self) -> str:
        beam = "" if self.uniform else f", beam_deg={self.beam_deg:g}"
        return (f"SpotLight(position={_fmt(self.position)}, direction={_fmt(self.direction)}, "
                f"power={_fmt(self.power)}, cone_deg={self.cone_deg:g}{beam})")


@dataclass(frozen=True, eq=False)
class AreaLight:
    """A diffuse (Lambertian) emitter: the object named ``object`` emits ``radiance`` (3,)
    W m^-2 sr^-1 RGB from the front of each face (where its face normal points, the
    counter-clockwise winding), as Mitsuba's ``area`` emitter.  ``mesh`` is that object's
    mesh (the :class:`Scene` checks that it is the object's); the power is
    ``pi * radiance * area``.  Built by the loader from an object's ``emission``."""

    object: str
    mesh: trimesh.Trimesh
    radiance: np.ndarray
    #: A radiance that varies over the surface (:class:`blockhash.scene.texture.Texture`,
    #: looked up at ``uv``, the mesh's (vertices, 2) texture coordinates); ``radiance`` is
    #: then its mean, which the power and the choice between lights take.
    texture: object = None
    uv: np.ndarray | None = None

    def __post_init__(self):
        with _owned(f"AreaLight {self.object!r}" if isinstance(self.object, str) else "AreaLight"):
            if self.texture is not None:
                uv = None if self.uv is None else np.asarray(self.uv, dtype=np.float64)
                if uv is None or uv.shape != (len(self.mesh.vertices), 2) or not np.isfinite(uv).all():
                    raise _FieldError("uv", "a textured radiance needs the mesh's texture "
                                      "coordinates, one finite pair a vertex")
                object.__setattr__(self, "uv", _readonly(uv))
            _string(self.object, "object", what="the emitting object's name")
            if not isinstance(self.mesh, trimesh.Trimesh):
                raise _FieldError("mesh", f"expected a trimesh.Trimesh; got {type(self.mesh).__name__}")
            check_mesh(self.mesh, "mesh")
            radiance = _rgb(self.radiance, "emission", what="emitted radiance in W m^-2 sr^-1")
            if not radiance.any():
                raise _FieldError("emission", "the light emits nothing (radiance 0 in every "
                                  "channel); expected W m^-2 sr^-1 > 0 in at least one channel, "
                                  "or leave emission out for an object that does not emit")
            object.__setattr__(self, "radiance", radiance)
            tri = np.asarray(self.mesh.triangles, dtype=np.float64)
            cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            areas = 0.5 * np.linalg.norm(cross, axis=1)
            total = float(areas.sum())
            if not total > 0.0 or not math.isfinite(total):
                raise _FieldError("mesh", f"the emitting mesh has zero area ({len(areas):,} "
                                  "degenerate triangles); an area light needs triangles of "
                                  "positive area: fix the mesh or its scale")
            live = areas > 0.0
            normals = np.zeros_like(cross)
            normals[live] = cross[live] / (2.0 * areas[live, None])
            object.__setattr__(self, "_triangles", _readonly(tri))
            object.__setattr__(self, "_areas", _readonly(areas))
            object.__setattr__(self, "_normals", _readonly(normals))
            cdf = np.cumsum(areas)
            object.__setattr__(self, "_cdf", _readonly(cdf / cdf[-1]))

    @property
    def triangles(self) -> np.ndarray:
        """(n, 3, 3) float64: the emitting triangles' corners."""
        return self._triangles

    @property
    def face_areas(self) -> np.ndarray:
        """(n,) float64 square metres (0 for a degenerate triangle, which emits nothing)."""
        return self._areas

    @property
    def face_normals(self) -> np.ndarray:
        """(n, 3) unit front-face normals (zeros for a degenerate triangle)."""
        return self._normals

    @property
    def area_cdf(self) -> np.ndarray:
        """(n,) the triangles' cumulative share of the area (the last 1)."""
        return self._cdf

    def points(self, u_face: np.ndarray, u1: np.ndarray, u2: np.ndarray):
        """(points (m, 3), front normals (m, 3)) uniform by area on the light: the triangle
        whose stretch of :attr:`area_cdf` holds ``u_face``, and in it the point of uniforms
        ``u1``, ``u2`` (barycentrics 1 - sqrt(u1), sqrt(u1) u2)."""
        f, b0, b2 = self._faces(u_face, u1, u2)
        tri = self._triangles[f]
        y = b0[:, None] * tri[:, 0] + (1.0 - b0 - b2)[:, None] * tri[:, 1] + b2[:, None] * tri[:, 2]
        return y, self._normals[f]

    def emitted_at(self, u_face: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> np.ndarray:
        """(m, 3) the radiance at the points :meth:`points` gives for the same uniforms."""
        if self.texture is None:
            return np.broadcast_to(self.radiance, (len(u_face), 3))
        f, b0, b2 = self._faces(u_face, u1, u2)
        return self.emitted_on(f, 1.0 - b0 - b2, b2)

    def _faces(self, u_face, u1, u2):
        """(triangle (m,), barycentrics b0, b2) of :meth:`points`' rule."""
        f = np.minimum(np.searchsorted(self._cdf, u_face, side="right"), len(self._cdf) - 1)
        s = np.sqrt(u1)
        return f, 1.0 - s, s * u2

    def emitted_on(self, face: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(m, 3) the radiance on the mesh's ``face`` at barycentrics ``u``, ``v`` (the point
        ``(1 - u - v) v0 + u v1 + v v2``, embree's)."""
        if self.texture is None:
            return np.broadcast_to(self.radiance, (len(face), 3))
        corners = self.uv[np.asarray(self.mesh.faces)[face]]  # (m, 3, 2)
        b = np.stack([1.0 - u - v, u, v], axis=1)
        return self.texture.value(np.einsum("ij,ijk->ik", b, corners))

    @property
    def area(self) -> float:
        return float(self._areas.sum())

    @property
    def power(self) -> np.ndarray:
        """(3,) watts: pi * radiance * area (Lambertian emission from one face)."""
        return math.pi * self.radiance * self.area

    def __repr__(self) -> str:
        return (f"AreaLight(object={self.object!r}, radiance={_fmt(self.radiance)}, "
                f"area={self.area:.6g} m^2)")


@dataclass(frozen=True, eq=False)
class DirectionalLight:
    """Sunlight: parallel light travelling along ``direction`` (3,) (normalised), of
    ``irradiance`` (3,) W m^-2 RGB on a surface perpendicular to it, as Mitsuba's
    ``directional`` emitter."""

    direction: np.ndarray
    irradiance: np.ndarray

    def __post_init__(self):
        with _owned("DirectionalLight"):
            d = _vector(self.direction, "direction", unit="a direction")
            length = float(np.linalg.norm(d))
            if length == 0.0:
                raise _FieldError("direction", "expected a non-zero direction the light travels "
                                  "along; got (0, 0, 0); e.g. [0, -1, 0] for light from straight "
                                  "above")
            object.__setattr__(self, "direction", _readonly(d / length))
            e = _rgb(self.irradiance, "irradiance", what="irradiance in W m^-2")
            if not e.any():
                raise _FieldError("irradiance", "the light emits nothing (irradiance 0 in every "
                                  "channel); expected W m^-2 > 0 in at least one channel")
            object.__setattr__(self, "irradiance", e)

    def __repr__(self) -> str:
        return (f"DirectionalLight(direction={_fmt(self.direction)}, "
                f"irradiance={_fmt(self.irradiance)})")


#: The light classes a :class:`Scene` takes.
LIGHTS = (PointLight, SpotLight, AreaLight, DirectionalLight, EnvironmentLight)


def check_lights(lights, objects) -> None:
    """Each light one of :data:`LIGHTS`; an area light's object in the scene, with its mesh,
    and not a mirror or glass (blockhash's emitters are diffuse surfaces)."""
    by_name = {o.name: o for o in objects}
    emitting = set()
    environments = 0
    for i, light in enumerate(lights):
        if not isinstance(light, LIGHTS):
            raise _FieldError(f"lights[{i}]", "expected a PointLight, SpotLight, AreaLight, "
                              f"DirectionalLight or EnvironmentLight; got {type(light).__name__}")
        if isinstance(light, EnvironmentLight) and environments:
            raise _FieldError(f"lights[{i}]", "a second environment light; give one (the sum "
                              "of their radiances, in one map)")
        environments += isinstance(light, EnvironmentLight)
        if not isinstance(light, AreaLight):
            continue
        obj = by_name.get(light.object)
        if obj is None:
            raise _FieldError(f"lights[{i}]", f"area light on object {light.object!r}, which the "
                              f"scene does not hold (objects: {sorted(by_name)}); add the object "
                              "or name one of those")
        if obj.is_specular:
            kind = "glass" if obj.is_dielectric else "mirror"
            raise _FieldError(f"lights[{i}]", f"area light on object {light.object!r}, a {kind}: "
                              "blockhash's emitters are diffuse surfaces; give the emitting "
                              "object a phong material, or put the light on another object")
        if light.mesh is not obj.mesh:
            raise _FieldError(f"lights[{i}]", f"area light on object {light.object!r} with a mesh "
                              "other than the object's; build it with AreaLight(object, "
                              "obj.mesh, radiance)")
        if light.object in emitting:
            raise _FieldError(f"lights[{i}]", f"object {light.object!r} carries two area lights; "
                              "give it one emission")
        emitting.add(light.object)
