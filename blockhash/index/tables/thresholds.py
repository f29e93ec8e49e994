"""Adaptive hash thresholds (paper sections 3.1 and 4.2).

The one-dimensional locality-sensitive hash of an axis is
``h(x) = #{i : t_i <= x}`` over its interior thresholds ``t_1 .. t_{P-1}``.
Thresholds are stratified samples of the inverse cumulative distribution of the
photon coordinates: they crowd where photons crowd, so buckets hold similar
numbers of photons.  The distribution is taken at full code resolution (the
histogram with one bin per code, i.e. the empirical CDF, interpolated between
order statistics); a coarser histogram would only add binning error.

Table ``t`` samples an axis at the quantiles ``(i + o[t, a]) / P_a`` for
``i = 1 .. P_a - 1``, with offsets ``o[t, a]`` in [-1/2, 1/2) from the additive
recurrence of the 3D golden ratio (Roberts' R3 sequence).  Offsets differ per
table and per axis, so the bucket boundaries of the L tables interleave and
their buckets complement each other around a query (Figure 2).

Layouts (``ThresholdLayout``): ``marginal`` (the paper's), built here: one threshold list
per axis, from that axis' marginal distribution; on clustered data the product of marginals
makes a grid whose cells hold very different numbers of photons (a hot spot's cells overflow
while most cells stay empty).  ``adaptive`` (the default preset's, :mod:`.adaptive`) is a
kd-tree of count thresholds per table, which this module hashes too.

Storage of a marginal row: one flat row of uint32 codes per table, axis x's list at 0
(length ``Px - 1``), y's at ``Px - 1``, z's at ``(Px - 1) + (Py - 1)``.  Thresholds are
fixed-point codes, so hashing is integer comparison that the CPU reference and the shader
agree on exactly.
"""

from __future__ import annotations

from enum import IntEnum

import numba
import numpy as np

from blockhash.errors import InputError

#: Padding of a table's unused row slots (adaptive rows shorter than the longest): codes
#: never reach 2**32 - 1 (the box is padded, and query codes saturate at 2**32 - 256), so a
#: padded slot never counts.
THRESHOLD_PAD = np.uint32(0xFFFFFFFF)
#: The plastic number (real root of x^3 = x + 1): R3 offsets are frac(t / phi^(a+1)).
_PHI3 = 1.2207440846057596


class ThresholdLayout(IntEnum):
    """How a table's thresholds are laid out; the value is the shader's define id (1 was
    the nested grid, retired: BENCHMARKS.md, "Threshold layouts")."""

    MARGINAL = 0
    ADAPTIVE = 2


#: Layouts that were retired, and what to use instead.
RETIRED_LAYOUTS = {"nested": "it was never more accurate than the adaptive layout (the default "
                             "preset's) and needs more rounds of dependent fetches than "
                             "'marginal' (BENCHMARKS.md, \"Threshold layouts\"); use layout="
                             "'adaptive' or, for the paper's grid, layout='marginal'"}


def table_offsets(L: int) -> np.ndarray:
    """(L, 3) float64 stratification offsets in [-1/2, 1/2), one row per table."""
    alpha = 1.0 / _PHI3 ** np.arange(1, 4)
    t = np.arange(L)[:, None]
    return np.mod(0.5 + t * alpha[None, :], 1.0) - 0.5


def row_starts(P) -> tuple[int, int, int, int]:
    """Start of the x, y and z lists of a marginal row, and the row's length."""
    px, py, pz = (int(p) for p in P)
    return 0, px - 1, (px - 1) + (py - 1), (px - 1) + (py - 1) + (pz - 1)


@numba.njit(cache=True, nogil=True, inline="always")
def count_le(thresholds, start, count, code):
    """#{thresholds[start + i] <= code : i < count} for a sorted list (binary search)."""
    lo = 0
    hi = count
    while lo < hi:
        mid = (lo + hi) >> 1
        if thresholds[start + mid] <= code:
            lo = mid + 1
        else:
            hi = mid
    return lo


#: ADAPTIVE layout (blockhash/index/tables/adaptive.py): the flag of a bucket node, and the deepest
#: tree a query descends (a loop bound; trees are about log2(N / S) deep).
LEAF = np.uint32(4)
MAX_DEPTH = 48


@numba.njit(cache=True, nogil=True, inline="always")
def adaptive_descent(row, cx, cy, cz):
    """(bucket, nodes read) of one code triple in one ``ADAPTIVE`` row (:mod:`.adaptive`):
    descend ``i = left + (code[axis] >= t)`` from node 0 to a bucket node (bucket -1 past
    ``MAX_DEPTH``); each node read waits on the one before."""
    i = 0
    for depth in range(1, MAX_DEPTH + 1):
        meta = row[2 * i + 1]
        if meta & LEAF:
            return np.int64(meta >> 3), depth
        a = meta & 3
        c = cx if a == 0 else (cy if a == 1 else cz)
        i = np.int64(meta >> 3) + (1 if c >= row[2 * i] else 0)
    return np.int64(-1), MAX_DEPTH


@numba.njit(cache=True, nogil=True, inline="always")
def adaptive_bucket_of(row, cx, cy, cz):
    """Bucket of one code triple in one ``ADAPTIVE`` row: :func:`adaptive_descent`'s."""
    return adaptive_descent(row, cx, cy, cz)[0]


@numba.njit(cache=True, nogil=True, parallel=True)
def descent_rounds(thresholds, layout, codes):
    """Per query, the longest chain of threshold fetches that each wait on the last, over
    the tables (they descend side by side): an ``ADAPTIVE`` row's depth to the query's
    bucket; 1 for ``MARGINAL`` (every threshold of a row can be fetched at once)."""
    n = codes.shape[0]
    out = np.zeros(n, dtype=np.int64)
    for j in numba.prange(n):
        if layout != 2:
            out[j] = 1
            continue
        deepest = 0
        for t in range(thresholds.shape[0]):
            _, depth = adaptive_descent(thresholds[t], codes[j, 0], codes[j, 1], codes[j, 2])
            deepest = max(deepest, depth)
        out[j] = deepest
    return out


#: Cuts nearest to the query, per table, that a multi-probe query may cross (PROBE_CUTS).
PROBE_CUTS = 3
#: A cut's distance in codes drops its low 8 bits before it becomes float32, so that the
#: value (below 2**24) converts exactly in every language (a shader's int-to-float rounding
#: need not match numpy's); cuts closer than 256 codes (2**-24 of the box) tie.
GAP_SHIFT = np.uint32(8)


@numba.njit(cache=True, nogil=True, inline="always")
def adaptive_descend(row, cx, cy, cz, step, cut_axis, cut_code, cut_gap):
    """Like :func:`adaptive_bucket_of`, and also the ``PROBE_CUTS`` cuts on the path nearest
    to the query: ``cut_gap`` (ascending, float32 ``(|code - t| >> GAP_SHIFT) * step[axis]``, inf
    where unused), ``cut_axis`` and ``cut_code``, the code on the cut's other side (``t - 1``
    when the query went right, ``t`` when it went left).  Returns the bucket."""
    for j in range(PROBE_CUTS):
        cut_gap[j] = np.float32(np.inf)
        cut_axis[j] = 0
        cut_code[j] = 0
    i = 0
    for _ in range(MAX_DEPTH):
        meta = row[2 * i + 1]
        if meta & LEAF:
            return np.int64(meta >> 3)
        a = meta & 3
        c = cx if a == 0 else (cy if a == 1 else cz)
        t = row[2 * i]
        right = c >= t
        gap = np.float32((c - t if right else t - c) >> GAP_SHIFT) * step[a]
        j = PROBE_CUTS
        while j > 0 and cut_gap[j - 1] > gap:
            if j < PROBE_CUTS:
                cut_gap[j] = cut_gap[j - 1]
                cut_axis[j] = cut_axis[j - 1]
                cut_code[j] = cut_code[j - 1]
            j -= 1
        if j < PROBE_CUTS:
            cut_gap[j] = gap
            cut_axis[j] = a
            cut_code[j] = t - 1 if right else t
        i = np.int64(meta >> 3) + (1 if right else 0)
    return np.int64(-1)


@numba.njit(cache=True, nogil=True, inline="always")
def bucket_of(thresholds, px, py, pz, layout, cx, cy, cz):
    """Bucket of one code triple in one table's row: ``hx + Px * (hy + Py * hz)`` for the
    marginal layout; ``layout`` is the layout's id (0 marginal, 2 adaptive)."""
    if layout == 2:
        return adaptive_bucket_of(thresholds, cx, cy, cz)
    hx = count_le(thresholds, 0, px - 1, cx)
    hy = count_le(thresholds, px - 1, py - 1, cy)
    hz = count_le(thresholds, (px - 1) + (py - 1), pz - 1, cz)
    return hx + px * (hy + py * hz)


@numba.njit(cache=True, nogil=True, parallel=True)
def _hash_all(codes, thresholds, px, py, pz, layout):
    L = thresholds.shape[0]
    n = codes.shape[0]
    keys = np.empty((L, n), dtype=np.int64)
    for j in numba.prange(n):
        for t in range(L):
            keys[t, j] = bucket_of(thresholds[t], px, py, pz, layout,
                                   codes[j, 0], codes[j, 1], codes[j, 2])
    return keys


@numba.njit(cache=True, nogil=True)
def _fill_quantiles(values, first, m, fractions, row, start):
    """row[start + i] = inverse empirical CDF of sorted values[first:first + m] at fractions[i]."""
    for i in range(fractions.shape[0]):
        pos = min(max(fractions[i] * m - 0.5, 0.0), m - 1.0)
        lo = int(np.floor(pos))
        hi = min(lo + 1, m - 1)
        w = pos - lo
        x = float(values[first + lo]) * (1.0 - w) + float(values[first + hi]) * w
        row[start + i] = np.uint32(np.floor(x))


@numba.njit(cache=True, nogil=True, parallel=True)
def _build_rows(xs, ys, zs, fx, fy, fz, sy, sz, out):
    """Each table's marginal thresholds, from each axis' sorted codes."""
    for t in numba.prange(out.shape[0]):
        row = out[t]
        if fx.shape[1] > 0:
            _fill_quantiles(xs, 0, xs.shape[0], fx[t], row, 0)
        if fy.shape[1] > 0:
            _fill_quantiles(ys, 0, ys.shape[0], fy[t], row, sy)
        if fz.shape[1] > 0:
            _fill_quantiles(zs, 0, zs.shape[0], fz[t], row, sz)


def build_thresholds(codes, P, L: int, layout: ThresholdLayout) -> tuple[np.ndarray, np.ndarray]:
    """Marginal thresholds of ``L`` tables with ``P = (Px, Py, Pz)`` buckets per axis.

    Parameters
    ----------
    codes : (n, 3) uint32
        Photon position codes.
    P : sequence of 3 int
        Buckets per axis (>= 1).
    L : int
        Number of tables.
    layout : ThresholdLayout
        ``MARGINAL`` (the adaptive layout is built by :mod:`.adaptive`).

    Returns
    -------
    thresholds : (L, T) uint32, laid out as the module docstring describes.
    keys : (L, n) int64, the bucket of every photon in every table (what
        :func:`hash_codes` returns, computed along the way).
    """
    if layout != ThresholdLayout.MARGINAL:
        raise InputError(f"build_thresholds builds the marginal layout, not {layout!r}; the "
                         "adaptive layout is built by blockhash.index.tables.adaptive.build_adaptive")
    _, sy, sz, T = row_starts(P)
    codes = np.ascontiguousarray(codes, dtype=np.uint32)
    out = np.full((L, T), THRESHOLD_PAD, dtype=np.uint32)
    offsets = table_offsets(L)
    # Each split axis' codes sorted once; every table reads its quantiles from them.
    axes = [np.sort(codes[:, a]) if p > 1 else codes[:1, a] for a, p in enumerate(P)]
    fractions = [(np.arange(1, int(p))[None, :] + offsets[:, a:a + 1]) / int(p)
                 for a, p in enumerate(P)]
    _build_rows(*axes, *fractions, sy, sz, out)
    return out, hash_codes(codes, out, P, layout)


def hash_codes(codes, thresholds, P, layout: ThresholdLayout) -> np.ndarray:
    """Bucket index of each code in each table: ``hx + Px * (hy + Py * hz)``.

    Parameters
    ----------
    codes : (n, 3) uint32
    thresholds : (L, T) uint32, from :func:`build_thresholds`
    P : (3,) buckets per axis
    layout : ThresholdLayout

    Returns
    -------
    keys : (L, n) int64, each in [0, Px * Py * Pz)
    """
    px, py, pz = (int(p) for p in P)
    return _hash_all(np.ascontiguousarray(codes, dtype=np.uint32), np.ascontiguousarray(thresholds),
                     px, py, pz, int(layout))
