"""Photon paths through mirrors and glass to their first diffuse hit (vectorised), and the
map they make: :class:`CausticPhotons`.  :mod:`.tracing` shoots them from the lights; the
light tracer (:mod:`blockhash.reference.lighttrace`) follows the same paths.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blockhash.photons.bounce import bounce, specular_events
from blockhash.scene.optics import choice_uniforms
from blockhash.scene.raycast import RAY_OFFSET, EmbreeGeometry

# Photon fates (per emitted photon); index into FATE_NAMES.
STORED, OUTSIDE_SPOT, MISSED, DIRECT, ESCAPED, ABSORBED, MAX_BOUNCES = range(7)
FATE_NAMES = ("stored", "outside_spot_cone", "missed", "direct_diffuse", "escaped",
              "absorbed", "exceeded_max_bounces")


@dataclass(frozen=True)
class CausticPhotons:
    """The caustic photon map: photons stored at their first diffuse hit after >= 1 mirror.

    Attributes
    ----------
    positions : (n, 3) float32 (traced maps; float64 where a caller built one so)
        Hit points on the receiving (non-specular) surface, in scene units.
    directions : (n, 3) float32
        Unit direction of travel when the photon arrives (pointing *into* the surface).
    normals : (n, 3) float32
        Unit shading normal of the receiver at the hit (barycentric interpolation of
        the mesh's ``vertex_normals``), flipped together with the geometric normal so
        that it lies on the side the photon came from: ``dot(geometric normal,
        direction) < 0``, and ``dot(normals, directions) < 0`` except where smooth
        shading normals lean past a grazing photon.
    powers : (n, 3) float32
        Flux carried by each photon, watts RGB; ``powers.sum(0)`` estimates the
        caustic flux reaching diffuse surfaces.
    emitted : int
        Photons shot toward the specular objects (including those that were dropped).
    stats : dict
        Counters: ``emitted``, ``hit_specular`` (first hit a mirror), ``stored`` and the
        fates of the rest (``outside_spot_cone``, ``missed``, ``direct_diffuse``,
        ``escaped``, ``absorbed``, ``exceeded_max_bounces``), ``max_depth_reached``
        (most mirror bounces of a stored photon), ``shading_normal_fallbacks``,
        ``emitted_per_light``, ``cones``, ``specular_objects`` (the names of the objects
        photons were shot toward), ``stopped_by`` (``'target'``, ``'cap'``, ``'nothing_stored'``
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
    #: (n,) int32 receiving object of each photon (index into the scene's objects), when the
    #: tracer knows it (None for a map built elsewhere).
    objects: np.ndarray | None = None

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


#: What a traced map keeps of each stored photon (:func:`compact`): float32 position,
#: direction, normal and power and an int32 object, 52 bytes (the records the index reads
#: hold 24; float64 would be 104).
STORED_FLOAT = np.float32
STORED_OBJECT = np.int32


def compact(positions, directions, normals, weights, objects) -> tuple:
    """One batch's stored photons in the dtypes a map keeps (:data:`STORED_FLOAT`)."""
    f = STORED_FLOAT
    return (positions.astype(f), directions.astype(f), normals.astype(f), weights.astype(f),
            objects.astype(STORED_OBJECT))


def joined(chunks: list) -> list:
    """The columns of ``chunks`` (a list of equal-length tuples of arrays, emptied here), each
    concatenated, a column's chunks freed as soon as it is joined: the peak is the chunks and
    one joined column, not twice the map."""
    columns = list(zip(*chunks))
    chunks.clear()
    out = []
    for i in range(len(columns)):
        out.append(np.concatenate(columns[i]))
        columns[i] = None
    return out


# --------------------------------------------------------------------------- tracing

@dataclass
class Batch:
    fate: np.ndarray        # (n,) int8
    fallbacks: np.ndarray   # (n,) uint16 shading-normal fallbacks per photon
    stored: np.ndarray      # (m,) local indices of stored photons, increasing
    positions: np.ndarray
    directions: np.ndarray
    normals: np.ndarray
    weights: np.ndarray
    depth: np.ndarray       # (m,) mirror bounces
    rays: int
    objects: np.ndarray     # (m,) receiving object (index into the scene's objects)
    geo_normals: np.ndarray  # (m, 3) geometric normals, on the side the photon came from

    def cut(self, end: int) -> "Batch":
        """Keep photons with local index < end."""
        keep = slice(0, int(np.searchsorted(self.stored, end)))  # ``stored`` increases
        return Batch(self.fate[:end], self.fallbacks[:end], self.stored[keep],
                      self.positions[keep], self.directions[keep], self.normals[keep],
                      self.weights[keep], self.depth[keep], self.rays, self.objects[keep],
                      self.geo_normals[keep])


def trace_batch(geom: EmbreeGeometry, origins, dirs, weights, max_bounces: int, *,
                seed: int = 0, start: int = 0) -> Batch:
    """Follow a batch of photons through mirrors and glass to their first diffuse hit
    (vectorised); a photon that meets a one-sided receiver's back face
    (:attr:`blockhash.scene.materials.PhongMaterial.sided`) after a specular event is absorbed
    there, not stored.

    Shared by the photon map (:func:`trace_caustic_photons`) and the light tracer
    (:mod:`blockhash.reference.lighttrace`); ``weights`` are not yet divided by the photons emitted.  At a
    dielectric a photon reflects or refracts with the Fresnel probabilities (the formulas of
    :func:`blockhash.scene.optics.scatter`, compiled in :mod:`.bounce`), drawing its choices from :func:`blockhash.scene.optics.choice_uniforms` of
    ``seed`` for photon ``start + i``, so a photon's path does not depend on the batch.
    """
    n = len(origins)
    fate = np.full(n, -1, dtype=np.int8)
    fallbacks = np.zeros(n, dtype=np.uint16)
    zero = ~np.any(weights > 0.0, axis=1)
    fate[zero] = OUTSIDE_SPOT
    idx = np.flatnonzero(~zero)
    d = np.ascontiguousarray(dirs[idx], dtype=np.float64)
    w = np.ascontiguousarray(weights[idx], dtype=np.float64)
    choices = (choice_uniforms(seed, start, n) if geom.draws
               else np.zeros((1, 1)))
    events = np.zeros(n, dtype=np.int64)  # dielectric events so far, per photon
    parts = []
    rays = 0
    offset = RAY_OFFSET * geom.scale
    # Start at the offset along the ray, as after a bounce: a light lying on a surface (a
    # lamp on the floor) would otherwise hit that surface at t = 0 with every photon.
    o = origins[idx] + d * offset
    tables = (geom.triangles, geom.vertex_normals, geom.face_normals, geom.face_object,
              geom.is_specular, geom.is_dielectric, geom.one_sided, geom.mirror, geom.ior,
              geom.tint)
    for b in range(max_bounces + 1):
        live = idx.size
        if live == 0:
            break
        rays += live
        hit, face, u, v = geom.intersect(o, d)
        stored = (np.empty(live, dtype=np.int64), np.empty((live, 3)), np.empty((live, 3)),
                  np.empty((live, 3)), np.empty((live, 3)), np.empty(live, dtype=np.int64),
                  np.empty((live, 3)))
        o = np.empty((live, 3))
        going, kept = bounce(b == 0, b == max_bounces, idx, d, w, hit, face, u, v, *tables,
                             choices, events, fallbacks, fate, offset, o, *stored)
        if kept:
            s_idx, s_p, s_d, s_n, s_w, s_obj, s_ng = (a[:kept] for a in stored)
            parts.append((s_idx, s_p, s_d, s_n, s_w, np.full(kept, b, dtype=np.uint8), s_obj,
                          s_ng))
        idx, d, w, o = idx[:going], d[:going], w[:going], o[:going]

    if len(parts) == 1:  # each bounce's photons are in photon order already
        s_idx, s_p, s_d, s_n, s_w, s_depth, s_obj, s_ng = parts[0]
    elif parts:
        cat = [np.concatenate(a) for a in zip(*parts)]
        order = np.argsort(cat[0], kind="stable")
        s_idx, s_p, s_d, s_n, s_w, s_depth, s_obj, s_ng = (a[order] for a in cat)
    else:
        s_idx = np.zeros(0, dtype=np.int64)
        s_p = s_d = s_n = s_w = s_ng = np.zeros((0, 3))
        s_depth = np.zeros(0, dtype=np.uint8)
        s_obj = np.zeros(0, dtype=np.int64)
    return Batch(fate, fallbacks, s_idx, s_p, s_d, s_n, s_w, s_depth, rays, s_obj, s_ng)


def specular_step(geom: EmbreeGeometry, idx, d, w, face, u, v, choices, events, fallbacks):
    """One specular event for photons ``idx`` (travelling along ``d`` with weights ``w``) at
    their hits (``face``, barycentrics ``u``, ``v``) on mirrors and glass: a mirror reflects
    (its reflectance on the weight; the geometric normal where the shading normal would send
    the photon into the surface, counted in ``fallbacks``), glass reflects or refracts by the
    Fresnel probabilities from ``choices`` (the photon's ``events``-th column, counted on);
    the compiled :func:`blockhash.photons.bounce.specular_events`, as the caustic tracer's
    bounce makes it.  Returns (the photons absorbed, whose weight fell to 0, and (idx, new
    directions, weights, hit points, geometric normals on the side they came from, +1 / -1
    for leaving on that side or passing through) of the others)."""
    m = len(idx)
    idx = np.array(idx, dtype=np.int64)
    d, w = np.array(d, dtype=np.float64), np.array(w, dtype=np.float64)
    p, ng, side = np.empty((m, 3)), np.empty((m, 3)), np.empty(m)
    absorbed = np.empty(m, dtype=np.int64)
    going, dead = specular_events(
        idx, d, w, np.ascontiguousarray(face, dtype=np.int64), np.ascontiguousarray(u, np.float64),
        np.ascontiguousarray(v, np.float64), geom.triangles, geom.vertex_normals,
        geom.face_normals, geom.face_object, geom.is_dielectric, geom.mirror, geom.ior,
        geom.tint, np.zeros((1, 1)) if choices is None else choices, events, fallbacks, p, ng,
        side, absorbed)
    return absorbed[:dead], (idx[:going], d[:going], w[:going], p[:going], ng[:going],
                             side[:going])
