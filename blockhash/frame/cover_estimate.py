"""The conserving estimate over the cover gather, on the CPU: the oracle of
glsl/caustic_cover.glsl.

At a shading point q with normal n and viewer direction wo, ``L = sum w(d / h) f_r(wi, wo)
Phi / (pi h^2)`` over every photon whose own disc covers q (``d < h``, its own radius:
:mod:`.photon_radius`), with the tests of :class:`~.estimate.EstimateOptions`: front side,
the stored normal, the flattened neighbourhood (height over the tangent plane at most ``disc
* h``: the photon's own radius, since the cover gather has no search radius) and the filter.
The photons come from :meth:`blockhash.index.lookups.cover.CoverGather.query`, the integer-exact
reference of the shader's gather.
"""

from __future__ import annotations

import weakref

import numpy as np

from blockhash.errors import InputError
from blockhash.frame.estimate import EstimateOptions, kernel
from blockhash.frame.photon_radius import own_radii2
from blockhash.index.lookups.cover import OCTAVE_STEPS, CoverGather
from blockhash.index.records.codec import decode_powers, unpack_records
from blockhash.index.records.octahedral import octahedral_decode
from blockhash.scene.materials import material_arrays, phong_brdf

#: Shading points estimated at once (their covering photons are decoded together).
CHUNK = 1 << 15

_GATHERS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def cover_gather(index, k: int, radii=None, *, steps: int = OCTAVE_STEPS) -> CoverGather:
    """The cover gather of ``index``'s photons with the radii of an estimate with k neighbours
    (``radii(index, k)``, default :func:`.photon_radius.own_radii2`); built once per index,
    k, radii and steps."""
    key = (int(k), radii, int(steps))
    per_index = _GATHERS.setdefault(index, {})
    if key not in per_index:
        per_index[key] = CoverGather.build(index, (radii or own_radii2)(index, k), steps=steps)
    return per_index[key]


def drop_gather(index, k: int, radii=None, *, steps: int = OCTAVE_STEPS) -> None:
    """Let go of :func:`cover_gather`'s gather of these arguments (a gather used once, such as
    a pass's gather of every photon for the points seen in mirrors)."""
    _GATHERS.get(index, {}).pop((int(k), radii, int(steps)), None)


def forget_gathers(index, keep=None) -> None:
    """Drop the gathers built on ``index`` but those with radii ``keep`` (an index kept for
    the next frame of an animation gathers with the next frame's radii, its pixel splat's; the
    last frame's would otherwise stay with it; the gather of every photon, radii ``keep``, does
    not depend on the camera and serves every frame)."""
    per_index = _GATHERS.get(index, {})
    for key in [key for key in per_index if keep is None or key[1] is not keep]:
        del per_index[key]


def require_conserving(options: EstimateOptions) -> None:
    if not options.conserving:
        raise InputError(f"the cover gather sums the conserving estimate only; estimate="
                         f"{options.estimate!r} needs the k nearest photons: use method='bh' "
                         "(the walk), 'kdtree' or the k-nearest CPU reference")


def estimate_cover_cpu(gather: CoverGather, points, materials,
                       options: EstimateOptions | None = None) -> np.ndarray:
    """(h, w, 3) float64 radiance of ``points`` (:class:`~.shading_points.ShadingPoints`)."""
    options = EstimateOptions() if options is None else options
    require_conserving(options)
    h, w = points.shape
    out = np.zeros((h * w, 3))
    pos = points.position.reshape(-1, 3)
    live = np.flatnonzero((points.material.reshape(-1) >= 0) & np.isfinite(pos).all(axis=1))
    kd, ks, e = material_arrays(materials)
    for start in range(0, len(live), CHUNK):
        rows = live[start:start + CHUNK]
        out[rows] = _radiance(gather, points, rows, (kd, ks, e), options)
    out *= points.weight.reshape(-1, 3)
    return out.reshape(h, w, 3)


def _radiance(gather, points, rows, table, options):
    q = points.position.reshape(-1, 3)[rows].astype(np.float32)
    cov = gather.query(q)
    which = np.repeat(np.arange(len(rows)), cov.counts)
    rec = gather.records[cov.records]
    words = np.zeros((len(rec), 6), dtype=np.uint32)
    words[:, 4:6] = rec[:, 6:8]
    pbits = unpack_records(words)[3]
    wi = octahedral_decode(rec[:, 4]).astype(np.float64)
    n_photon = octahedral_decode(rec[:, 5]).astype(np.float64)
    power = decode_powers(pbits, gather.power_scale)[:, :3].astype(np.float64)
    h2 = rec[:, 3].view(np.float32).astype(np.float64)
    offset = rec[:, :3].view(np.float32).astype(np.float64) - q[which].astype(np.float64)
    n = points.normal.reshape(-1, 3)[rows].astype(np.float64)[which]
    wo = points.view.reshape(-1, 3)[rows].astype(np.float64)[which]
    keep = np.einsum("ij,ij->i", wi, n) > 0
    if options.normal_cos is not None:
        keep &= np.einsum("ij,ij->i", n_photon, n) >= options.normal_cos
    if options.disc is not None:
        keep &= np.abs(np.einsum("ij,ij->i", offset, n)) <= options.disc * np.sqrt(h2)
    weight = np.where(keep, kernel(options.filter, cov.d2.astype(np.float64) / h2) / h2, 0.0)
    mid = points.material.reshape(-1)[rows][which]
    kd, ks, e = table
    f = phong_brdf(wi, wo, n, kd[mid], ks[mid], e[mid])
    contrib = weight[:, None] * f * power
    L = np.stack([np.bincount(which, contrib[:, c], minlength=len(rows)) for c in range(3)], axis=1)
    return L / np.pi
