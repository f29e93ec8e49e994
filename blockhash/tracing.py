"""Caustic photon tracing: Jensen's caustic photon map (paper sections 1 and 6).

Photons leave each light only toward the specular objects, bounce off perfect
mirrors and are stored at the first non-specular (modified Phong) hit, so the map
holds the caustic paths L S+ D and nothing else.  Direct light is the renderer's
job (shadow rays), so photons whose first hit is diffuse are dropped.

Emission (importance sampling toward the mirrors, still unbiased):

* For every light and every specular object there is a *bounding cone*: apex at
  the light, axis toward the centre of the object's bounding sphere, half-angle
  the largest angle to any vertex (at most the bounding sphere's cone, usually
  tighter; a half-angle below 90 degrees makes the cone convex, so it contains
  every triangle).  A spot light's cone replaces the object's cone where it is
  the smaller one; where the two cones only overlap, the smaller one is sampled
  and photons outside the spot cone carry nothing.
* A photon picks a light and one of its cones with probability proportional to
  the light's power falling into the cone (``pmf``), then a direction uniform in
  solid angle inside that cone.  Its weight is ``I(w) / q(w)`` where ``I`` is
  the light's intensity (power / emission solid angle, zero outside a spot cone)
  and ``q`` the full mixture density of the direction (overlapping cones of one
  light are counted together), and its power is ``weight / emitted``.  With one
  light and one cone this is ``power * cone_solid_angle / emission_solid_angle /
  photons_shot`` (one-sample MIS over lights and cones; the light's share of
  photons is its share of the power into the cones).
* Photons that miss the mirrors inside the cone, or hit a diffuse surface first,
  carry no caustic: they are dropped but count as emitted.

Determinism: photon ``i`` draws its four uniforms from
``Philox(key=seed, counter=i)`` (one counter step = four 64-bit words), so every
result is the same whatever ``batch_size`` (pbrt-v4 SPPM's per-index streams).

Stopping: photons are shot in index order until the ``n+1``-th caustic photon
appears at index ``g``; the map keeps the first ``n`` and ``emitted = g``.  That
is the unbiased negative-binomial estimator ``(k-1)/(N-1)`` (keeping the ``n``-th
photon and ``emitted = g+1`` would bias the flux by about ``1/n``), and it does
not depend on the batch size.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .validate import as_int

#: Ray origins leaving a mirror move this far along its geometric normal, relative
#: to the scene's bounding-box diagonal.  embree works in float32 (ulp 2.4e-7 at 2 m);
#: 1e-5 of a 4 m scene is 4e-5 m, ~170 ulps, still 750x thinner than the ring wall.
RAY_OFFSET = 1e-5
#: Bounding cones are widened by this much (in cosine) against rounding.
CONE_MARGIN = 1e-9
#: A sampled direction counts as inside a cone when its cosine to the axis is at
#: least cos(half-angle) - CONE_TEST_EPS: cone sampling rounds in the last bits.
CONE_TEST_EPS = 1e-12
#: Default safety cap on emitted photons, as a multiple of the stored target
#: (with at least DEFAULT_MIN_CAP).  The ring scene stores ~30% of the photons
#: shot into its cone; 1% efficiency would still finish well under the cap.
DEFAULT_CAP_FACTOR = 100
DEFAULT_MIN_CAP = 1_000_000
#: With nothing stored after this many photons the mirror is taken as unreachable.
ZERO_STORED_ABORT = 1_000_000
#: Batches are sized from the fraction stored so far, with this margin, so that the
#: photons traced past the target (discarded) stay few.
OVERSHOOT = 1.1
#: Random numbers per photon: cone choice, two for the direction, one spare
#: (one Philox counter step gives four).
UNIFORMS_PER_PHOTON = 4

# Photon fates (per emitted photon); index into FATE_NAMES.
STORED, OUTSIDE_SPOT, MISSED, DIRECT, ESCAPED, ABSORBED, MAX_BOUNCES = range(7)
FATE_NAMES = ("stored", "outside_spot_cone", "missed", "direct_diffuse", "escaped",
              "absorbed", "exceeded_max_bounces")


class TracingWarning(UserWarning):
    """Fewer caustic photons than asked for: the safety cap on emitted photons was reached."""


@dataclass(frozen=True)
class CausticPhotons:
    """The caustic photon map: photons stored at their first diffuse hit after >= 1 mirror.

    Attributes
    ----------
    positions : (n, 3) float64
        Hit points on the receiving (non-specular) surface, in scene units.
    directions : (n, 3) float64
        Unit direction of travel when the photon arrives (pointing *into* the surface).
    normals : (n, 3) float64
        Unit shading normal of the receiver at the hit (barycentric interpolation of
        the mesh's ``vertex_normals``), flipped together with the geometric normal so
        that it lies on the side the photon came from: ``dot(geometric normal,
        direction) < 0``, and ``dot(normals, directions) < 0`` except where smooth
        shading normals lean past a grazing photon.
    powers : (n, 3) float64
        Flux carried by each photon, watts RGB; ``powers.sum(0)`` estimates the
        caustic flux reaching diffuse surfaces.
    emitted : int
        Photons shot toward the specular objects (including those that were dropped).
    stats : dict
        Counters: ``emitted``, ``hit_specular`` (first hit a mirror), ``stored`` and the
        fates of the rest (``outside_spot_cone``, ``missed``, ``direct_diffuse``,
        ``escaped``, ``absorbed``, ``exceeded_max_bounces``), ``max_depth_reached``
        (most mirror bounces of a stored photon), ``shading_normal_fallbacks``,
        ``emitted_per_light``, ``cones``, ``stopped_by`` (``'target'``, ``'cap'``
        or ``'no_specular_objects'``), and performance counters that do depend on
        the batch size (``traced`` incl. the discarded overshoot, ``rays_cast``,
        ``batches``, ``seconds``).
    """

    positions: np.ndarray
    directions: np.ndarray
    normals: np.ndarray
    powers: np.ndarray
    emitted: int
    stats: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.positions.shape[0])

    @property
    def total_power(self) -> np.ndarray:
        """(3,) float64: the flux of all stored photons, watts RGB."""
        return self.powers.sum(axis=0)

    @classmethod
    def empty(cls, stats: dict | None = None) -> "CausticPhotons":
        z = np.zeros((0, 3), dtype=np.float64)
        return cls(z, z.copy(), z.copy(), z.copy(), 0, dict(stats or {}))

    def __repr__(self) -> str:
        flux = ", ".join(f"{p:.4g}" for p in self.total_power)
        return (f"CausticPhotons(n={len(self):,}, emitted={self.emitted:,}, "
                f"flux=({flux}) W, stopped_by={self.stats.get('stopped_by')!r})")


# --------------------------------------------------------------------------- numpy helpers

def cone_solid_angle(cos_half: float | np.ndarray):
    """Solid angle (sr) of a cone with the given cosine of its half-angle."""
    return 2.0 * np.pi * (1.0 - np.asarray(cos_half, dtype=np.float64))


def orthonormal_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,) completing unit ``axis`` to a right-handed frame (Duff et al. 2017)."""
    x, y, z = (float(c) for c in axis)
    sign = 1.0 if z >= 0.0 else -1.0
    a = -1.0 / (sign + z)
    b = x * y * a
    t1 = np.array([1.0 + sign * x * x * a, sign * b, -sign * x])
    t2 = np.array([b, sign + y * y * a, -y])
    return t1, t2


def sample_cones(axes, t1, t2, cos_half, u1, u2) -> np.ndarray:
    """(n, 3) directions uniform in solid angle inside per-photon cones.

    ``axes``, ``t1``, ``t2`` are (n, 3) orthonormal frames, ``cos_half`` (n,),
    ``u1``, ``u2`` (n,) uniforms in [0, 1).
    """
    cos_t = 1.0 - u1 * (1.0 - cos_half)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
    phi = 2.0 * np.pi * u2
    d = (cos_t[:, None] * axes + (sin_t * np.cos(phi))[:, None] * t1
         + (sin_t * np.sin(phi))[:, None] * t2)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def reflect(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(n, 3) mirror reflection of directions ``d`` about unit normals ``n``."""
    return d - 2.0 * np.sum(d * n, axis=1, keepdims=True) * n


def photon_uniforms(seed: int, start: int, count: int) -> np.ndarray:
    """(count, 4) uniforms in [0, 1) of photons ``start .. start+count-1``.

    Row ``i`` comes from Philox counter ``start + i`` under key ``seed`` alone,
    so any photon's numbers are the same however the photons are batched.
    """
    bitgen = np.random.Philox(key=seed, counter=start)
    return np.random.Generator(bitgen).random((count, UNIFORMS_PER_PHOTON))


def bounding_cone(apex: np.ndarray, vertices: np.ndarray, center: np.ndarray):
    """(axis (3,), cos_half) of a cone from ``apex`` containing every vertex.

    The axis points at ``center``; the half-angle is the largest angle to a vertex.
    A cone of 90 degrees or more is not convex, so it becomes the whole sphere
    (``cos_half = -1``), as does an apex inside the geometry's bounding sphere.
    """
    axis = center - apex
    dist = np.linalg.norm(axis)
    w = vertices - apex
    wn = np.linalg.norm(w, axis=1)
    radius = float(np.max(np.linalg.norm(vertices - center, axis=1)))
    if dist <= radius or wn.min() <= 0.0:
        return np.array([0.0, 0.0, 1.0]), -1.0
    axis = axis / dist
    cos_half = float(np.min((w @ axis) / wn)) - CONE_MARGIN
    if cos_half <= 0.0:
        return axis, -1.0
    return axis, cos_half


# --------------------------------------------------------------------------- scene pieces

def _scene_name(scene) -> str:
    path = getattr(scene, "path", None)
    return f"scene {str(path)!r}" if path else "scene (built in code, no path)"


class _Geometry:
    """All meshes of a scene in one embree scene, with per-triangle lookup tables.

    embree numbers the meshes (geomID) 0, 1, ... in the order they are added and
    the triangles (primID) within each; ``face_offset[geomID] + primID`` indexes the
    concatenated float64 tables.  At least one mesh must have triangles.
    """

    def __init__(self, objects, specular_ids: set[int]):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        self.embree = rtcore_scene.EmbreeScene()
        self._keep = []  # TriangleMesh objects must outlive the scene
        geom_faces, tri, vnrm, fnrm, fobj = [], [], [], [], []
        self.is_specular = np.array([id(o) in specular_ids for o in objects], dtype=bool)
        self.reflectance = np.zeros((len(objects), 3))
        all_vertices = []
        for i, obj in enumerate(objects):
            if self.is_specular[i]:
                self.reflectance[i] = np.asarray(obj.material.reflectance, dtype=np.float64)
            mesh = obj.mesh
            faces = np.asarray(mesh.faces, dtype=np.int64)
            if len(faces) == 0:
                continue
            verts = np.asarray(mesh.vertices, dtype=np.float64)
            all_vertices.append(verts)
            self._keep.append(TriangleMesh(scene=self.embree,
                                           vertices=np.ascontiguousarray(verts, dtype=np.float32),
                                           indices=np.ascontiguousarray(faces, dtype=np.int32)))
            geom_faces.append(len(faces))
            tri.append(verts[faces])
            vnrm.append(np.asarray(mesh.vertex_normals, dtype=np.float64)[faces])
            fnrm.append(np.asarray(mesh.face_normals, dtype=np.float64))
            fobj.append(np.full(len(faces), i, dtype=np.int64))
        # geomIDs are assigned 0, 1, ... in creation order
        self.face_offset = np.concatenate([[0], np.cumsum(geom_faces)]).astype(np.int64)
        self.triangles = np.concatenate(tri)
        self.vertex_normals = np.concatenate(vnrm)
        self.face_normals = np.concatenate(fnrm)
        self.face_object = np.concatenate(fobj)
        allv = np.concatenate(all_vertices)
        self.scale = float(np.linalg.norm(allv.max(axis=0) - allv.min(axis=0))) or 1.0

    def intersect(self, origins: np.ndarray, dirs: np.ndarray):
        """First hits: (hit mask (n,), global face (m,), u (m,), v (m,)) for the hit rays."""
        res = self.embree.run(np.ascontiguousarray(origins, dtype=np.float32),
                              np.ascontiguousarray(dirs, dtype=np.float32), output=1)
        geom = res["geomID"]
        hit = (geom >= 0) & np.isfinite(res["tfar"]) & (res["primID"] >= 0)
        face = self.face_offset[geom[hit]] + res["primID"][hit].astype(np.int64)
        return hit, face, res["u"][hit].astype(np.float64), res["v"][hit].astype(np.float64)


@dataclass(frozen=True)
class _Cone:
    light: int
    object_name: str
    axis: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    cos_half: float
    sampled: str  # 'object' or 'spot'

    @property
    def solid_angle(self) -> float:
        return float(cone_solid_angle(self.cos_half))


class _Emitter:
    """Cone sampling toward the specular objects for every light."""

    def __init__(self, lights, specular_objects):
        self.positions, self.intensity, self.spot_axis, self.spot_cos = [], [], [], []
        cones: list[_Cone] = []
        for li, light in enumerate(lights):
            pos = np.asarray(light.position, dtype=np.float64)
            power = np.asarray(light.power, dtype=np.float64)
            cone_deg = getattr(light, "cone_deg", None)
            if cone_deg is None:
                emit_sa, s_axis, s_cos = 4.0 * np.pi, None, -1.0
            else:
                s_axis = np.asarray(light.direction, dtype=np.float64)
                s_axis = s_axis / np.linalg.norm(s_axis)
                s_cos = float(np.cos(np.radians(float(cone_deg))))
                emit_sa = float(cone_solid_angle(s_cos))
            self.positions.append(pos)
            self.intensity.append(power / emit_sa)
            self.spot_axis.append(s_axis)
            self.spot_cos.append(s_cos)
            for obj in specular_objects:
                if len(obj.mesh.faces) == 0:
                    continue
                verts = np.asarray(obj.mesh.vertices, dtype=np.float64)
                center = 0.5 * (verts.min(axis=0) + verts.max(axis=0))
                axis, cos_a = bounding_cone(pos, verts, center)
                chosen = self._clip_to_spot(axis, cos_a, s_axis, s_cos)
                if chosen is None:
                    continue
                axis, cos_h, which = chosen
                t1, t2 = orthonormal_basis(axis)
                cones.append(_Cone(li, str(obj.name), axis, t1, t2, cos_h, which))
        self.cones = tuple(cones)
        self.n_lights = len(lights)
        # pmf over cones: power of the light falling into each cone
        brightness = np.array([float(np.mean(self.intensity[c.light])) * c.solid_angle
                               for c in cones])
        total = brightness.sum() if len(cones) else 0.0
        self.pmf = brightness / total if total > 0 else brightness
        self.cdf = np.cumsum(self.pmf)
        if len(cones):
            self.cdf[-1] = 1.0
        self.total_brightness = total

    @staticmethod
    def _clip_to_spot(axis, cos_a, s_axis, s_cos):
        """The cone to sample for an object cone and a spot cone, or None when they are disjoint."""
        if s_axis is None:
            return axis, cos_a, "object"
        alpha = np.arccos(np.clip(cos_a, -1.0, 1.0))
        beta = np.arccos(np.clip(s_cos, -1.0, 1.0))
        gamma = np.arccos(np.clip(float(axis @ s_axis), -1.0, 1.0))
        if gamma >= alpha + beta:
            return None
        if gamma + alpha <= beta:
            return axis, cos_a, "object"
        if gamma + beta <= alpha:
            return s_axis, s_cos, "spot"
        # partial overlap: sample the smaller cone, photons outside the spot carry nothing
        return (axis, cos_a, "object") if cos_a >= s_cos else (s_axis, s_cos, "spot")

    def sample(self, u: np.ndarray):
        """Origins (n, 3), unit directions (n, 3), weights (n, 3) and light index (n,) from uniforms (n, 4)."""
        k = np.minimum(np.searchsorted(self.cdf, u[:, 0], side="right"), len(self.cones) - 1)
        axes = np.array([c.axis for c in self.cones])
        t1 = np.array([c.t1 for c in self.cones])
        t2 = np.array([c.t2 for c in self.cones])
        cos_h = np.array([c.cos_half for c in self.cones])
        dirs = sample_cones(axes[k], t1[k], t2[k], cos_h[k], u[:, 1], u[:, 2])
        light = np.array([c.light for c in self.cones], dtype=np.int64)[k]
        origins = np.array(self.positions)[light]
        # mixture density q(w) = sum over cones c containing w of pmf_c / solid_angle_c
        q = (self.pmf / np.array([c.solid_angle for c in self.cones]))[k]
        for j, c in enumerate(self.cones):
            other = (k != j) & (light == c.light)
            if other.any():
                inside = dirs[other] @ c.axis >= c.cos_half - CONE_TEST_EPS
                q[np.flatnonzero(other)[inside]] += self.pmf[j] / c.solid_angle
        weights = np.array(self.intensity)[light] / q[:, None]
        for li in range(self.n_lights):
            if self.spot_axis[li] is None:
                continue
            sel = light == li
            outside = dirs[sel] @ self.spot_axis[li] < self.spot_cos[li] - CONE_TEST_EPS
            weights[np.flatnonzero(sel)[outside]] = 0.0
        return origins, dirs, weights, light


# --------------------------------------------------------------------------- tracing

@dataclass
class _Batch:
    fate: np.ndarray        # (n,) int8
    fallbacks: np.ndarray   # (n,) uint16 shading-normal fallbacks per photon
    stored: np.ndarray      # (m,) local indices of stored photons, increasing
    positions: np.ndarray
    directions: np.ndarray
    normals: np.ndarray
    weights: np.ndarray
    depth: np.ndarray       # (m,) mirror bounces
    rays: int

    def cut(self, end: int) -> "_Batch":
        """Keep photons with local index < end."""
        keep = self.stored < end
        return _Batch(self.fate[:end], self.fallbacks[:end], self.stored[keep],
                      self.positions[keep], self.directions[keep], self.normals[keep],
                      self.weights[keep], self.depth[keep], self.rays)


def _surface(geom: _Geometry, face, u, v, d):
    """Hit points, shading normals and geometric normals (each (m, 3)) of hits on ``face``.

    Points and shading normals interpolate with embree's barycentrics
    (``p = (1-u-v) v0 + u v1 + v v2``); both normals are flipped to face the side
    the photon came from (mirrors and receivers are two-sided).
    """
    tri = geom.triangles[face]
    vn = geom.vertex_normals[face]
    b0, b1, b2 = (1.0 - u - v)[:, None], u[:, None], v[:, None]
    p = b0 * tri[:, 0] + b1 * tri[:, 1] + b2 * tri[:, 2]
    ns = b0 * vn[:, 0] + b1 * vn[:, 1] + b2 * vn[:, 2]
    ng = geom.face_normals[face]
    length = np.sqrt(np.einsum("ij,ij->i", ns, ns))
    bad = length < 1e-12  # normals that cancel: fall back to the face normal
    if bad.any():
        ns[bad], length[bad] = ng[bad], 1.0
    sgn = np.where(np.einsum("ij,ij->i", d, ng) > 0.0, -1.0, 1.0)
    return p, ns * (sgn / length)[:, None], ng * sgn[:, None]


def _trace_batch(geom: _Geometry, origins, dirs, weights, max_bounces: int) -> _Batch:
    """Follow a batch of photons through mirrors to their first diffuse hit (vectorised)."""
    n = len(origins)
    fate = np.full(n, -1, dtype=np.int8)
    fallbacks = np.zeros(n, dtype=np.uint16)
    zero = ~np.any(weights > 0.0, axis=1)
    fate[zero] = OUTSIDE_SPOT
    idx = np.flatnonzero(~zero)
    o, d, w = origins[idx], dirs[idx], weights[idx]
    parts = []
    rays = 0
    offset = RAY_OFFSET * geom.scale
    for bounce in range(max_bounces + 1):
        if idx.size == 0:
            break
        rays += idx.size
        hit, face, u, v = geom.intersect(o, d)
        fate[idx[~hit]] = MISSED if bounce == 0 else ESCAPED
        idx, d, w = idx[hit], d[hit], w[hit]
        spec = geom.is_specular[geom.face_object[face]]
        diffuse = ~spec
        if bounce == 0:
            fate[idx[diffuse]] = DIRECT  # direct light: the renderer's shadow rays do it
        elif diffuse.any():
            fate[idx[diffuse]] = STORED
            p, ns, _ = _surface(geom, face[diffuse], u[diffuse], v[diffuse], d[diffuse])
            parts.append((idx[diffuse], p, d[diffuse], ns, w[diffuse],
                          np.full(len(p), bounce, dtype=np.uint8)))
        if bounce == max_bounces:
            fate[idx[spec]] = MAX_BOUNCES
            break
        idx, d, w, face = idx[spec], d[spec], w[spec], face[spec]
        p, ns, ng = _surface(geom, face, u[spec], v[spec], d)
        w = w * geom.reflectance[geom.face_object[face]]
        r = reflect(d, ns)
        under = np.einsum("ij,ij->i", r, ng) <= 0.0  # shading normal sent it into the surface
        if under.any():
            r[under] = reflect(d[under], ng[under])
            fallbacks[idx[under]] += 1
        r /= np.sqrt(np.einsum("ij,ij->i", r, r))[:, None]
        dead = ~np.any(w > 0.0, axis=1)
        if dead.any():
            fate[idx[dead]] = ABSORBED
            live = ~dead
            idx, r, w, p, ng = idx[live], r[live], w[live], p[live], ng[live]
        d = r
        o = p + ng * offset

    if parts:
        cat = [np.concatenate(a) for a in zip(*parts)]
        order = np.argsort(cat[0], kind="stable")
        s_idx, s_p, s_d, s_n, s_w, s_depth = (a[order] for a in cat)
    else:
        s_idx = np.zeros(0, dtype=np.int64)
        s_p = s_d = s_n = s_w = np.zeros((0, 3))
        s_depth = np.zeros(0, dtype=np.uint8)
    return _Batch(fate, fallbacks, s_idx, s_p, s_d, s_n, s_w, s_depth, rays)


def trace_caustic_photons(scene, n_stored_target: int | None = None, *, seed: int | None = None,
                          batch_size: int = 65536, max_emitted: int | None = None,
                          progress: bool = False) -> CausticPhotons:
    """Trace the caustic photon map of ``scene`` (paths light -> mirror(s) -> diffuse).

    Parameters
    ----------
    scene : blockhash.scene.Scene
        Lights (point: ``position``, ``power``; spot: also ``direction``, ``cone_deg``),
        objects (trimesh meshes; ``scene.specular_objects`` are perfect mirrors with
        ``material.reflectance``), ``photons`` (``count``, ``seed``, ``max_bounces``).
    n_stored_target : int, optional
        Caustic photons to store; default ``scene.photons.count``.  Exactly this many
        are kept unless the cap is reached first.
    seed : int, optional
        Non-negative random seed; default ``scene.photons.seed``.
    batch_size : int
        Photons traced per vectorised batch; results do not depend on it.
    max_emitted : int, optional
        Safety cap on emitted photons; default ``max(100 * n_stored_target, 1,000,000)``.
        Reaching it with some photons stored warns (:class:`TracingWarning`); with none
        stored (or none after 1,000,000 emitted) raises :class:`InputError`.
    progress : bool
        Show a tqdm bar of stored photons.

    Returns
    -------
    CausticPhotons
        Empty (``stats['stopped_by'] == 'no_specular_objects'``) when the scene has no
        mirror: there is no caustic, and the renderer shows direct light only.

    Raises
    ------
    InputError
        No lights; ``max_bounces`` < 1; lights with no power toward the mirrors; no
        light reaching any mirror (spot cones miss, occluders, wrong side).
    """
    t0 = time.perf_counter()
    name = _scene_name(scene)
    settings = scene.photons
    target = as_int(settings.count if n_stored_target is None else n_stored_target,
                    "n_stored_target", minimum=1)
    seed = as_int(settings.seed if seed is None else seed, "seed", minimum=0,
                  maximum=2**128 - 1, hint="use a non-negative integer seed")
    batch_size = as_int(batch_size, "batch_size", minimum=1)
    max_bounces = as_int(settings.max_bounces, "photons.max_bounces", minimum=1,
                         hint=f"{name}: caustic paths need at least one mirror bounce")
    cap = as_int(max(DEFAULT_CAP_FACTOR * target, DEFAULT_MIN_CAP) if max_emitted is None
                 else max_emitted, "max_emitted", minimum=1)

    lights = tuple(scene.lights)
    if not lights:
        raise InputError(f"{name} has no lights; caustic photons need at least one point or "
                         "spot light: add a [[lights]] entry")
    specular = tuple(scene.specular_objects)
    if not specular:
        return CausticPhotons.empty({
            "emitted": 0, "hit_specular": 0, "stored": 0, "stopped_by": "no_specular_objects",
            "reason": f"{name} has no specular (mirror) object, so it has no caustic",
            "seconds": time.perf_counter() - t0})

    emitter = _Emitter(lights, specular)
    if not emitter.cones:
        raise InputError(
            f"{name}: no light reaches a specular object (every spot light's cone misses "
            f"the mirrors {[o.name for o in specular]}); aim a spot light at a mirror or widen "
            "its cone_deg")
    if emitter.total_brightness <= 0.0:
        raise InputError(f"{name}: the lights that face the mirrors have zero power; "
                         "give a light a positive power")
    spec_ids = {id(o) for o in specular}
    geom = _Geometry(tuple(scene.objects), spec_ids)

    fate_counts = np.zeros(len(FATE_NAMES), dtype=np.int64)
    light_counts = np.zeros(len(lights), dtype=np.int64)
    chunks: list[_Batch] = []
    stored = fallbacks = rays = batches = traced = 0
    start = 0
    stopped_by = "cap"
    bar = None
    if progress:
        from tqdm.auto import tqdm
        bar = tqdm(total=target, unit="photon", desc="caustic photons")
    try:
        while start < cap:
            # size the batch to what is still needed (results do not depend on it)
            need = target + 1 - stored
            if stored:
                guess = int(need * start / stored * OVERSHOOT) + 256
            else:
                guess = 4 * need + 1024 if start == 0 else batch_size
            count = min(batch_size, cap - start, guess)
            u = photon_uniforms(seed, start, count)
            origins, dirs, weights, light = emitter.sample(u)
            batch = _trace_batch(geom, origins, dirs, weights, max_bounces)
            batches += 1
            traced += count
            rays += batch.rays
            done = len(batch.stored) >= need
            if done:
                end = int(batch.stored[need - 1])  # the (target+1)-th photon: not kept
                batch = batch.cut(end)
                light = light[:end]
                count = end
                stopped_by = "target"
            fate_counts += np.bincount(batch.fate, minlength=len(FATE_NAMES))
            light_counts += np.bincount(light, minlength=len(lights))
            fallbacks += int(batch.fallbacks.sum())
            chunks.append(batch)
            stored += len(batch.stored)
            start += count
            if bar is not None:
                bar.update(min(len(batch.stored), target - bar.n))
            if done:
                break
            if stored == 0 and start >= ZERO_STORED_ABORT:
                break
    finally:
        if bar is not None:
            bar.close()
    emitted = start

    if stored == 0:
        raise InputError(
            f"{name}: no caustic photon stored after {emitted:,} photons shot toward the "
            f"mirrors {[o.name for o in specular]} (fates: "
            f"{dict(zip(FATE_NAMES, fate_counts.tolist()))}); the mirrors are not reachable "
            "from the lights, or nothing diffuse receives their reflection: move the light, "
            "remove the occluder or add a receiver")
    if stored < target:
        warnings.warn(
            f"{name}: only {stored:,} of n_stored_target={target:,} caustic photons after "
            f"max_emitted={cap:,} photons; the mirrors catch little of the light. Raise "
            "max_emitted or lower n_stored_target", TracingWarning, stacklevel=2)

    positions = np.concatenate([c.positions for c in chunks])
    powers = np.concatenate([c.weights for c in chunks]) / float(emitted)
    depth = np.concatenate([c.depth for c in chunks])
    stats = {
        "emitted": emitted,
        "hit_specular": int(emitted - fate_counts[[OUTSIDE_SPOT, MISSED, DIRECT]].sum()),
        **{k: int(v) for k, v in zip(FATE_NAMES, fate_counts)},
        "max_depth_reached": int(depth.max()),
        "shading_normal_fallbacks": fallbacks,
        "emitted_per_light": tuple(int(c) for c in light_counts),
        "cones": tuple({"light": c.light, "object": c.object_name, "sampled": c.sampled,
                        "half_angle_deg": float(np.degrees(np.arccos(c.cos_half))),
                        "solid_angle": c.solid_angle, "pmf": float(p)}
                       for c, p in zip(emitter.cones, emitter.pmf)),
        "stopped_by": stopped_by,
        "traced": traced, "rays_cast": rays, "batches": batches,
        "seconds": time.perf_counter() - t0,
    }
    return CausticPhotons(positions=positions,
                          directions=np.concatenate([c.directions for c in chunks]),
                          normals=np.concatenate([c.normals for c in chunks]),
                          powers=powers, emitted=emitted, stats=stats)
