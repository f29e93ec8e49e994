"""The scene model: camera, materials, lights, objects and photon settings.

Frozen dataclasses that validate their own values (every error an
:class:`~blockhash.errors.InputError` naming the key path); :mod:`.loader`
reads them from a TOML file and documents that format.  Units are metres and
watts, y is up, the frame is right-handed.

The dataclasses are frozen and their arrays read-only; all but
``PhotonSettings`` compare by identity (numpy arrays have no single truth value).
Do not modify an object's mesh in place: trimesh would recompute its vertex
normals from the faces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import trimesh

from blockhash.errors import InputError
from blockhash.scene.lights import (  # noqa: F401 (the lights, importable from here)
    LIGHTS,
    AreaLight,
    DirectionalLight,
    EnvironmentLight,
    PointLight,
    SpotLight,
    check_lights,
)
from blockhash.scene.materials import SPECULAR_MATERIALS, DielectricMaterial, MirrorMaterial, PhongMaterial  # noqa: F401
from blockhash.scene.pixel_filter import BOX, PixelFilter, pixel_filter
from blockhash.scene.values import FieldError as _FieldError
from blockhash.scene.values import check_mesh  # noqa: F401 (importable from here)
from blockhash.scene.values import fmt as _fmt
from blockhash.scene.values import integer as _integer
from blockhash.scene.values import number as _number
from blockhash.scene.values import owned as _owned
from blockhash.scene.values import readonly as _readonly
from blockhash.scene.values import string as _string
from blockhash.scene.values import vector as _vector

#: Largest image side: GL_MAX_TEXTURE_SIZE on llvmpipe (16,384), so a
#: G-buffer of the camera's size can be allocated.
MAX_IMAGE_SIDE = 16384
#: up and the view direction count as parallel when the sine of their angle is
#: below this: the camera basis (cross products) would then be mostly rounding.
PARALLEL_SINE = 1e-6


# --------------------------------------------------------------------------- dataclasses

@dataclass(frozen=True, eq=False)
class Camera:
    """A pinhole camera.

    ``eye``, ``target``, ``up`` : (3,) float64, metres; ``fov_y_deg`` the
    vertical field of view in degrees; ``width``, ``height`` the image size in
    pixels.  ``up`` need not be perpendicular to the view direction, only not
    parallel to it.  ``spp``: samples per pixel per pass, 1 to
    :data:`blockhash.scene.camera.MAX_SPP`, stratified in cells as near square as the count
    divides (:func:`blockhash.scene.camera.spp_grid`; None: the renderer's default,
    :data:`blockhash.scene.camera.DEFAULT_SPP`).  ``filter``: the pixel filter
    (:mod:`blockhash.scene.pixel_filter`; default the box, each pixel its samples' mean).
    ``crop``: None (the whole film), or ``(x0, y0, x1, y1)``, the part of the film the image
    holds as fractions of it (y from the top; :meth:`window`).  ``aperture_radius`` > 0: a thin
    lens of that radius in the plane of ``eye`` (right and up), in focus at
    ``focus_distance`` along the view axis (depth of field, as Mitsuba's ``thinlens``); 0 a
    pinhole.
    """

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    fov_y_deg: float
    width: int
    height: int
    spp: int | None = None
    filter: PixelFilter = BOX
    crop: tuple | None = None
    aperture_radius: float = 0.0
    focus_distance: float = 1.0

    def __post_init__(self):
        with _owned("Camera"):
            if self.crop is not None:
                object.__setattr__(self, "crop", _crop(self.crop))
            object.__setattr__(self, "aperture_radius", _number(
                self.aperture_radius, "aperture_radius", lo=0.0,
                hint="the lens's radius in scene units; 0 for a pinhole"))
            object.__setattr__(self, "focus_distance", _number(
                self.focus_distance, "focus_distance", lo=0.0, lo_open=True,
                hint="the distance of the plane in focus along the view axis, > 0"))
            set_ = object.__setattr__
            set_(self, "eye", _vector(self.eye, "eye"))
            set_(self, "target", _vector(self.target, "target"))
            set_(self, "up", _vector(self.up, "up", unit="a direction"))
            set_(self, "fov_y_deg", _number(self.fov_y_deg, "fov_y_deg", lo=0.0, hi=180.0,
                                            lo_open=True, hi_open=True,
                                            hint="give the vertical field of view in degrees, e.g. 38"))
            set_(self, "width", _integer(self.width, "width", lo=1, hi=MAX_IMAGE_SIDE))
            set_(self, "height", _integer(self.height, "height", lo=1, hi=MAX_IMAGE_SIDE))
            if self.spp is not None:
                from blockhash.scene.camera import MAX_SPP
                set_(self, "spp", _integer(self.spp, "spp", lo=1, hi=MAX_SPP,
                                           hint=f"give 1 to {MAX_SPP} samples per pixel"))
            set_(self, "filter", pixel_filter(self.filter))
            view = self.target - self.eye
            dist = float(np.linalg.norm(view))
            if dist == 0.0:
                raise _FieldError("target", f"target {_fmt(self.target)} equals eye; expected a "
                                  "point the camera looks at, away from the eye")
            up_len = float(np.linalg.norm(self.up))
            if up_len == 0.0:
                raise _FieldError("up", "expected a non-zero direction; got (0, 0, 0); use [0, 1, 0]")
            sine = float(np.linalg.norm(np.cross(view / dist, self.up / up_len)))
            if sine < PARALLEL_SINE:
                raise _FieldError("up", f"up {_fmt(self.up)} is parallel to the view direction "
                                  f"target - eye = {_fmt(view)}; expected a direction not parallel "
                                  "to it; for a camera looking straight down use e.g. up = [0, 0, -1]")

    @property
    def aspect(self) -> float:
        """width / height."""
        return self.width / self.height

    def window(self) -> tuple[float, float, float, float]:
        """``(tan_x, tan_y, cx, cy)``: the image's half extents and its centre on the image
        plane at distance 1 (x right, y up).  The field of view is the whole film's; a
        ``crop`` ``(x0, y0, x1, y1)`` (fractions of the film, y from the top) takes that part
        of it, as a film's crop window in Mitsuba: ``width`` x ``height`` pixels of it."""
        tan_y = math.tan(math.radians(self.fov_y_deg) / 2.0)
        if self.crop is None:
            return tan_y * self.aspect, tan_y, 0.0, 0.0
        x0, y0, x1, y1 = self.crop
        tan_x = tan_y * (self.width / (x1 - x0)) / (self.height / (y1 - y0))
        return (tan_x * (x1 - x0), tan_y * (y1 - y0), (x0 + x1 - 1.0) * tan_x,
                (1.0 - y0 - y1) * tan_y)

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit ``(right, true_up, forward)`` vectors of the camera frame."""
        forward = self.target - self.eye
        forward = forward / np.linalg.norm(forward)
        right = np.cross(forward, self.up)
        right /= np.linalg.norm(right)
        return right, np.cross(right, forward), forward

    def view_matrix(self) -> np.ndarray:
        """(4, 4) float64 world-to-camera matrix (gluLookAt): right-handed, the
        camera at the origin looking down ``-z`` with ``+y`` up."""
        right, up, forward = self.basis()
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = right, up, -forward
        m[:3, 3] = -m[:3, :3] @ self.eye
        return m

    def projection(self, near: float, far: float) -> np.ndarray:
        """(4, 4) float64 OpenGL perspective matrix (gluPerspective, off axis for a crop,
        :meth:`window`) for this camera's field of view and aspect, mapping ``z = -near`` and ``z = -far``
        in camera space to NDC depth -1 and +1.  Needs ``0 < near < far``."""
        near = _number(near, "near", lo=0.0, lo_open=True)
        far = _number(far, "far", lo=0.0, lo_open=True)
        if near >= far:
            raise InputError(f"projection: near={near} must be < far={far}; "
                             "pass a near plane closer than the far one")
        tan_x, tan_y, cx, cy = self.window()
        m = np.zeros((4, 4))
        m[0, 0], m[1, 1] = 1.0 / tan_x, 1.0 / tan_y
        m[0, 2], m[1, 2] = cx / tan_x, cy / tan_y  # off axis: a crop of the film
        m[2, 2], m[2, 3] = (far + near) / (near - far), 2.0 * far * near / (near - far)
        m[3, 2] = -1.0
        return m

    def __repr__(self) -> str:
        return (f"Camera(eye={_fmt(self.eye)}, target={_fmt(self.target)}, up={_fmt(self.up)}, "
                f"fov_y_deg={self.fov_y_deg:g}, width={self.width}, height={self.height})")


def _crop(value) -> tuple:
    """A camera's crop window, (x0, y0, x1, y1) with 0 <= x0 < x1 <= 1 and the same for y."""
    try:
        x0, y0, x1, y1 = (float(v) for v in value)
    except (TypeError, ValueError):
        raise _FieldError("crop", f"expected [x0, y0, x1, y1], fractions of the film; got "
                          f"{value!r}") from None
    if not (0.0 <= x0 < x1 <= 1.0 and 0.0 <= y0 < y1 <= 1.0):
        raise _FieldError("crop", f"expected 0 <= x0 < x1 <= 1 and 0 <= y0 < y1 <= 1 (fractions "
                          f"of the film, y from the top); got {[x0, y0, x1, y1]}")
    return (x0, y0, x1, y1)


@dataclass(frozen=True, eq=False)
class SceneObject:
    """A named triangle mesh with a material.  ``mesh.vertex_normals`` are the
    normals to shade with (smooth radial ones on the ring's walls, flat on
    planes, the smooth surface's on the bust)."""

    name: str
    mesh: trimesh.Trimesh
    material: PhongMaterial | MirrorMaterial | DielectricMaterial
    #: (vertices, 2) texture coordinates, one pair a vertex of ``mesh``: where a textured
    #: material (:attr:`PhongMaterial.texture`) is looked up; None where the mesh has none.
    uv: np.ndarray | None = None

    def __post_init__(self):
        with _owned("SceneObject"):
            _string(self.name, "name", what="the object's name")
            if not isinstance(self.mesh, trimesh.Trimesh):
                raise _FieldError("mesh", f"expected a trimesh.Trimesh; got {type(self.mesh).__name__}")
            check_mesh(self.mesh, "mesh")
            if not isinstance(self.material, (PhongMaterial, *SPECULAR_MATERIALS)):
                raise _FieldError("material", "expected a PhongMaterial, MirrorMaterial or "
                                  f"DielectricMaterial; got {type(self.material).__name__}")
            if self.uv is not None:
                uv = np.asarray(self.uv, dtype=np.float64)
                if uv.shape != (len(self.mesh.vertices), 2) or not np.isfinite(uv).all():
                    raise _FieldError("uv", f"expected ({len(self.mesh.vertices):,}, 2) finite "
                                      f"texture coordinates, one pair a vertex; got shape "
                                      f"{uv.shape}")
                object.__setattr__(self, "uv", _readonly(uv))
            if getattr(self.material, "texture", None) is not None and self.uv is None:
                raise _FieldError("uv", "a textured material needs the mesh's texture "
                                  "coordinates; give uv (one pair a vertex), or a plain kd")

    @property
    def is_specular(self) -> bool:
        return isinstance(self.material, SPECULAR_MATERIALS)

    @property
    def is_dielectric(self) -> bool:
        return isinstance(self.material, DielectricMaterial)

    def __repr__(self) -> str:
        return (f"SceneObject(name={self.name!r}, mesh=<{len(self.mesh.vertices):,} vertices, "
                f"{len(self.mesh.faces):,} triangles>, material={self.material!r})")


#: Specular events a photon follows unless the scene says: 4, or 8 in a scene that holds a
#: dielectric (a path through a glass ball is already two events; internal reflections
#: add more).
MAX_BOUNCES = 4
DIELECTRIC_MAX_BOUNCES = 8


@dataclass(frozen=True)
class PhotonSettings:
    """Photon tracing and lookup settings: ``count`` photons to store (a
    target), ``k`` photons per estimate, accuracy multiplier ``A`` (section
    4.3), ``seed``, and ``max_bounces`` specular events (mirror bounces, glass
    reflections and refractions) followed per photon; None lets the
    :class:`Scene` choose: :data:`MAX_BOUNCES`, or :data:`DIELECTRIC_MAX_BOUNCES`
    when it holds a dielectric.  ``direct_only``: trace no photon at all (the direct layer
    alone, as Mitsuba's ``direct`` integrator renders); ``camera_bounces``: the specular events
    the camera's rays follow (None: blockhash's own, 4 or 8 with glass)."""

    count: int = 200_000
    k: int = 50
    A: int = 8
    seed: int = 1
    max_bounces: int | None = None
    #: Direct light only: no caustic or indirect photons (Mitsuba's ``direct`` integrator).
    direct_only: bool = False
    #: Specular events the camera's rays follow (None: blockhash's, 4 or 8 with glass).
    camera_bounces: int | None = None
    #: Surface events an indirect photon meets at most (None: ``max_bounces`` + 1; Mitsuba's
    #: unbounded depth: :data:`blockhash.scene.mitsuba.integrator.UNBOUNDED_EVENTS`).
    indirect_events: int | None = None

    def __post_init__(self):
        with _owned("PhotonSettings"):
            _integer(self.count, "count", lo=1)
            _integer(self.k, "k", lo=1, hi=self.count,
                     hint="k cannot exceed the photon count; lower k or raise count")
            _integer(self.A, "A", lo=1)
            _integer(self.seed, "seed", lo=0, hi=2**63 - 1)
            names = ["count", "k", "A", "seed"]
            if self.max_bounces is not None:
                _integer(self.max_bounces, "max_bounces", lo=1)
                names.append("max_bounces")
            if self.camera_bounces is not None:
                _integer(self.camera_bounces, "camera_bounces", lo=0)
                names.append("camera_bounces")
            if self.indirect_events is not None:
                _integer(self.indirect_events, "indirect_events", lo=2)
                names.append("indirect_events")
            for name in names:
                object.__setattr__(self, name, int(getattr(self, name)))
            if not isinstance(self.direct_only, (bool, np.bool_)):
                raise _FieldError("direct_only", f"expected true or false; got {self.direct_only!r}")
            object.__setattr__(self, "direct_only", bool(self.direct_only))


@dataclass(frozen=True, eq=False)
class Scene:
    """A loaded scene.  ``lights`` and ``objects`` are tuples; ``path`` is the
    file it came from (as given), ``None`` for a scene parsed from text."""

    camera: Camera
    lights: tuple
    objects: tuple
    photons: PhotonSettings = field(default_factory=PhotonSettings)
    path: Path | None = None
    description: str = ""
    #: The keyframes of an animated scene (:class:`blockhash.scene.animation.Animation`),
    #: None for a still.
    animation: object = None

    def __post_init__(self):
        with _owned("Scene"):
            object.__setattr__(self, "lights", tuple(self.lights))
            object.__setattr__(self, "objects", tuple(self.objects))
            if not self.lights:
                raise _FieldError("lights", "the scene has no light; add a [[lights]] table "
                                  "or an object with emission = [r, g, b]")
            if not self.objects:
                raise _FieldError("objects", "the scene has no object; add an [[objects]] table")
            names = [o.name for o in self.objects]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise _FieldError("objects", f"object names must be unique; {dup} used more than once")
            check_lights(self.lights, self.objects)
            if self.photons.max_bounces is None:
                glass = any(o.is_dielectric for o in self.objects)
                object.__setattr__(self, "photons", replace(
                    self.photons, max_bounces=DIELECTRIC_MAX_BOUNCES if glass else MAX_BOUNCES))

    @property
    def specular_objects(self) -> tuple[SceneObject, ...]:
        """The objects that cast caustics: those with a :class:`MirrorMaterial` or
        :class:`DielectricMaterial`, and coated receivers (:attr:`PhongMaterial.coat`), whose
        coats reflect."""
        return tuple(o for o in self.objects
                     if o.is_specular or getattr(o.material, "coat", 0.0) > 0.0)

    @property
    def diffuse_objects(self) -> tuple[SceneObject, ...]:
        """Objects with a :class:`PhongMaterial` (they receive the caustics)."""
        return tuple(o for o in self.objects if isinstance(o.material, PhongMaterial))

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) float64: the box around every object's mesh, [min, max]."""
        boxes = np.array([o.mesh.bounds for o in self.objects])
        return np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])

    def with_size(self, width: int, height: int) -> "Scene":
        """The same scene with the camera's image ``width`` x ``height`` (Camera checks them)."""
        return replace(self, camera=replace(self.camera, width=width, height=height))

    def summary(self) -> str:
        """A few lines describing the scene, for the command line."""
        c = self.camera
        lines = [f"scene {self.path if self.path else '(from text)'}"
                 + (f": {self.description}" if self.description else ""),
                 f"  camera  eye {_fmt(c.eye)} -> target {_fmt(c.target)}, up {_fmt(c.up)}, "
                 f"fov {c.fov_y_deg:g} deg, {c.width} x {c.height}"]
        for light in self.lights:
            if isinstance(light, AreaLight):
                lines.append(f"  light   area on {light.object!r}, radiance {_fmt(light.radiance)} "
                             f"W/m^2/sr, {light.area:.4g} m^2, power {_fmt(light.power)} W")
            elif isinstance(light, DirectionalLight):
                lines.append(f"  light   directional along {_fmt(light.direction)}, irradiance "
                             f"{_fmt(light.irradiance)} W/m^2")
            elif isinstance(light, EnvironmentLight):
                h, w = light.image.shape[:2]
                lines.append(f"  light   environment {light.name!r}, {w} x {h} pixels, radiance "
                             f"over the sphere {_fmt(light.integral)} W/m^2")
            elif isinstance(light, SpotLight):
                lines.append(f"  light   spot at {_fmt(light.position)} along {_fmt(light.direction)}, "
                             f"cone {light.cone_deg:g} deg"
                             + ("" if light.uniform else f" (beam {light.beam_deg:g} deg)")
                             + f", power {_fmt(light.power)} W")
            else:
                lines.append(f"  light   point at {_fmt(light.position)}, power {_fmt(light.power)} W")
        width = max(len(o.name) for o in self.objects)
        for o in self.objects:
            m = o.material
            mat = (f"mirror, reflectance {_fmt(m.reflectance)}"
                   + (f", conductor eta {_fmt(m.eta)} k {_fmt(m.k)}"
                      if getattr(m, "is_conductor", False) else "")
                   if isinstance(m, MirrorMaterial)
                   else f"dielectric, ior {m.ior:g}, tint {_fmt(m.tint)}"
                   if isinstance(m, DielectricMaterial)
                   else f"phong, kd {_fmt(m.kd)}, ks {_fmt(m.ks)}, n {m.n:g}"
                   + (", one-sided" if m.one_sided else ""))
            lines.append(f"  object  {o.name:<{width}}  {len(o.mesh.faces):>9,} triangles  {mat}")
        p = self.photons
        lines.append(f"  photons {p.count:,} stored, k {p.k}, A {p.A}, seed {p.seed}, "
                     f"max {p.max_bounces} bounces")
        lo, hi = self.bounds
        lines.append(f"  bounds  {_fmt(lo)} .. {_fmt(hi)} m")
        if not self.specular_objects:
            lines.append("  note    no specular (mirror or glass) object: the scene has no caustics")
        a = self.animation
        if a is not None:
            moving = (["camera orbit"] if a.orbit else ["camera"] if a.camera else []) + \
                [f"light {i}" for i in a.lights] + [f"object {n!r}" for n in a.objects]
            lines.append(f"  frames  {a.frames} at {a.fps:g} fps; keyed: {', '.join(moving) or 'nothing'}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (f"Scene(path={str(self.path) if self.path else None!r}, {len(self.lights)} light(s), "
                f"objects={[o.name for o in self.objects]}, photons={self.photons!r})")

