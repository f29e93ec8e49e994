"""The exact distance from every photon to its j-th nearest other photon, over the octree of
the Hilbert order (the photon radii of the conserving estimate).

Photons in Hilbert order (:mod:`.hilbert`, 21 bits per axis of the 32-bit codes) put every
cube of the octree over those codes in one contiguous run, found by two binary searches of the
sorted keys (:mod:`.cells` stores some of them in a hash; here no table is built).  At level l
(cube side ``2^(11 + l)`` codes) the 3 x 3 x 3 cubes around a photon's own hold every photon
within one side of it: when the j-th nearest of their photons lies within a side (less the
float32 position error), it is the exact j-th nearest; otherwise the next level up is read.
The top level is one cube, the whole box, so the search always ends.

A photon starts at the level whose side holds 1.2 times the radius of the photon before it in
Hilbert order (:data:`GUESS`; neighbours in Hilbert order have alike radii, and the level
follows the photon's own neighbourhood even where a sparse own cube lies beside a dense
caustic line).  The first photon of a task, and one after a far, lone photon, start at the
level whose own cube holds a quarter of j + 1 photons.  Consecutive photons share their cube,
and its 27 runs are copied once into contiguous coordinate arrays: each photon's squared
distances to all of them are one loop the compiler vectorises, and the j-th comes from the
candidates within the guess when j + 1 lie there (about 1.44 j of them on a surface), else
from all of them (:func:`_kth`: ranks counted in branch-free loops, or Hoare's selection).
Among the candidates within the guess, only those on the j-th's side of 1 / GUESS times the
photon before's radius are ranked (:func:`_kth_in_band`, about half of them: ``python
tools/photon_kernels.py`` times the radii beside a commit without it).

Distances are float64 from the float32 decoded positions, as ``scipy.spatial.cKDTree`` computes
them from the same positions: the result equals its j-th neighbour distance (the tests hold it
to it exactly).
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.errors import InputError
from blockhash.index.records.hilbert import KEY_BITS_PER_AXIS, hilbert_key, hilbert_keys, transition_tables
from blockhash.index.records.select import select_by

#: Low code bits below the Hilbert key's 21 per axis.
CODE_SHIFT = 32 - KEY_BITS_PER_AXIS
#: The first photon of a task starts at the finest level whose own cube holds at least
#: ``ceil(CMIN_FRACTION * (j + 1))`` photons (every photon did, before :data:`GUESS`; the
#: value was chosen then, on the ring at 10^6 photons).
CMIN_FRACTION = 0.25
#: Every later photon starts at the finest level whose cube side holds GUESS times the radius
#: of the photon before it, and reads only the candidates within that distance when j + 1 lie
#: there (``python tools/photon_radii.py scenes/ring.toml scenes/venus.toml --photons 1e6
#: --times-only`` times it; BENCHMARKS.md, "Photon radii").
GUESS = 1.2
#: Candidates, in units of j + 1, past which a photon's guessed level falls back to the
#: own-cube rule when that is finer (the photon after a far, lone one).
CROWD = 64
#: Candidates up to which the j-th is found by counting ranks (:func:`_rank_select`),
#: above it by Hoare's selection (:func:`blockhash.index.records.select.select_by`).
RANK_MAX = 128
#: Consecutive photons per parallel task.
CHUNK = 4096


def jth_distances(sorted_codes: np.ndarray, positions: np.ndarray, j: int, quantizer) -> np.ndarray:
    """(n,) float64 distance from each photon to its j-th nearest other photon (1 <= j < n).

    ``sorted_codes`` (n, 3) uint32 in Hilbert order; ``positions`` (n, 3) float32, the same
    photons decoded by ``quantizer`` (:class:`.fixedpoint.Quantizer`: its step, one on every
    axis, and its decode error bound).
    """
    n = len(sorted_codes)
    if not 1 <= j < n:
        raise InputError(f"j={j} must lie in [1, {n - 1}]: the rank of another photon of {n}")
    keys = hilbert_keys(np.ascontiguousarray(sorted_codes, dtype=np.uint32))
    single, pair, start = transition_tables()
    pos = np.ascontiguousarray(positions, dtype=np.float64)
    cmin = max(1, int(np.ceil(CMIN_FRACTION * (j + 1))))
    step = float(np.asarray(quantizer.step, dtype=np.float64).max())
    margin = 2.0 * float(np.asarray(quantizer.decode_error).max())
    return _jth(np.ascontiguousarray(sorted_codes, dtype=np.uint32), pos, keys, j, cmin, step,
                margin, single, pair, start)


@numba.njit(cache=True, nogil=True, inline="always")
def _run(keys, prefix, level):
    """[lo, hi) of the photons whose key has ``prefix`` at ``level`` (3 key bits a level)."""
    shift = np.uint64(3 * level)
    lo_key = np.uint64(prefix) << shift
    lo = np.searchsorted(keys, lo_key)
    if level >= KEY_BITS_PER_AXIS:
        return np.int64(0), np.int64(keys.shape[0])
    hi = np.searchsorted(keys, (np.uint64(prefix) + np.uint64(1)) << shift)
    return np.int64(lo), np.int64(hi)


@numba.njit(cache=True, nogil=True)
def _own_level(keys, key, cmin):
    """The finest level whose cube around ``key`` holds at least ``cmin`` photons."""
    level = 0
    while level < KEY_BITS_PER_AXIS:
        a, b = _run(keys, key >> np.uint64(3 * level), level)
        if b - a >= cmin:
            break
        level += 1
    return level


@numba.njit(cache=True, nogil=True)
def _neighbour_runs(codes_i, level, keys, single, pair, start, runs):
    """The runs of the 3 x 3 x 3 cubes of ``level`` around the cube holding ``codes_i``, its own
    first: ``runs`` ((27, 5): first, end, and the cube's coordinates); returns how many are
    filled (cubes outside the box or without photons are left out)."""
    top = np.int64(1) << np.int64(KEY_BITS_PER_AXIS - level)
    shift = np.int64(CODE_SHIFT + level)  # up to 32: in int64, where a shift by 32 is defined
    cx = np.int64(codes_i[0]) >> shift
    cy = np.int64(codes_i[1]) >> shift
    cz = np.int64(codes_i[2]) >> shift
    m = 0
    for o in range(27):
        # offset 13 (0, 0, 0) first, then the others in order
        oo = 13 if o == 0 else (o - 1 if o <= 13 else o)
        x = cx + oo // 9 - 1
        y = cy + (oo // 3) % 3 - 1
        z = cz + oo % 3 - 1
        if x < 0 or x >= top or y < 0 or y >= top or z < 0 or z >= top:
            continue
        key = hilbert_key(x << level, y << level, z << level, KEY_BITS_PER_AXIS, single, pair, start)
        lo, hi = _run(keys, key >> np.uint64(3 * level), level)
        if hi > lo:
            runs[m, 0] = lo
            runs[m, 1] = hi
            runs[m, 2] = x
            runs[m, 3] = y
            runs[m, 4] = z
            m += 1
    return m


@numba.njit(cache=True, nogil=True)
def _rank_select(a, m, kth):
    """The kth smallest (0-based) of a[:m] by counting, for each element, those below it and
    those not above it: m^2 comparisons in loops the compiler vectorises, no branch on the
    data (faster than a selection's data-dependent swaps when m is a few dozen)."""
    for i in range(m):
        v = a[i]
        less = 0
        leq = 0
        for b in range(m):
            less += a[b] < v
            leq += a[b] <= v
        if less <= kth < leq:
            return v
    return a[kth]


@numba.njit(cache=True, nogil=True)
def _kth(a, m, kth, order):
    """The kth smallest (0-based) of a[:m], leaving ``a`` as it is: by counting ranks up to
    :data:`RANK_MAX` values, above by Hoare's selection over ``order`` (scratch, at least m)."""
    if m <= RANK_MAX:
        return _rank_select(a, m, kth)
    for c in range(m):
        order[c] = c
    select_by(order, 0, m, kth, a)
    return a[order[kth]]


@numba.njit(cache=True, nogil=True)
def _kth_in_band(a, m, kth, low, order):
    """:func:`_kth` of a[:m], selecting among the values of one side of ``low`` only: those
    at or above it, offset by the count below, when the kth lies there, else those below.
    ``low``, 1 / GUESS times the photon before's radius, squared, leaves about half of the
    candidates within the guess above it; the selection's cost goes as their square.
    Reorders a[:m]."""
    below = 0
    for c in range(m):
        below += a[c] < low
    keep_low = below > kth
    n = 0
    for c in range(m):
        v = a[c]
        a[n] = v  # kept only on the chosen side: no branch
        n += (v < low) == keep_low
    return _kth(a, np.int64(n), kth if keep_low else kth - below, order)


@numba.njit(cache=True, nogil=True, parallel=True)
def _jth(codes, pos, keys, j, cmin, step, margin, single, pair, start):
    n = codes.shape[0]
    out = np.empty(n)
    # The parallel loop only calls the task's function, compiled on its own: numba's
    # parallel pass then reads one call, not the whole search (a cold start's compilation).
    for t in numba.prange((n + CHUNK - 1) // CHUNK):
        _jth_task(codes, pos, keys, j, cmin, step, margin, single, pair, start,
                  t * CHUNK, min(n, (t + 1) * CHUNK), out)
    return out


@numba.njit(cache=True, nogil=True)
def _jth_task(codes, pos, keys, j, cmin, step, margin, single, pair, start, first, end, out):
    """:func:`_jth` for photons ``first .. end - 1``, into ``out``."""
    runs = np.empty((27, 5), dtype=np.int64)
    buf = np.empty((5, 1024))  # per candidate: x, y, z, squared distance; the near ones
    xs, ys, zs, d2, near = buf[0], buf[1], buf[2], buf[3], buf[4]
    order = np.empty(1024, dtype=np.int64)
    m = 0
    cached_level = -1
    cached_prefix = np.uint64(0)
    prev = -1.0
    for i in range(first, end):
        if prev >= 0:
            # The finest level whose cubes' side holds the guess (GUESS times the photon
            # before's radius): its 27 cubes then hold the j-th nearest, whatever the
            # density beside the photon (a sparse own cube beside a dense caustic line).
            g = GUESS * prev + margin
            level = 0
            side0 = step * (2.0 ** CODE_SHIFT)
            while level < KEY_BITS_PER_AXIS and side0 < g:
                side0 *= 2.0  # exact: a power of two times the step
                level += 1
        else:
            level = _own_level(keys, keys[i], cmin)
        crowded = prev < 0
        x, y, z = pos[i, 0], pos[i, 1], pos[i, 2]
        while True:
            prefix = keys[i] >> np.uint64(3 * level) if level < KEY_BITS_PER_AXIS else np.uint64(0)
            if level != cached_level or prefix != cached_prefix:
                filled = _neighbour_runs(codes[i], level, keys, single, pair, start, runs)
                total = 0
                for r in range(filled):
                    total += runs[r, 1] - runs[r, 0]
                if not crowded and total > CROWD * (j + 1):
                    # A guess far too wide for this photon's neighbourhood (the photon
                    # before lay far from the others): the own-cube rule, if finer.
                    crowded = True
                    own = _own_level(keys, keys[i], cmin)
                    if own < level:
                        level = own
                        continue
                if total > buf.shape[1]:
                    buf = np.empty((5, 2 * total))
                    xs, ys, zs, d2, near = buf[0], buf[1], buf[2], buf[3], buf[4]
                    order = np.empty(2 * total, dtype=np.int64)
                m = 0
                for r in range(filled):
                    for c in range(runs[r, 0], runs[r, 1]):
                        xs[m] = pos[c, 0]
                        ys[m] = pos[c, 1]
                        zs[m] = pos[c, 2]
                        m += 1
                cached_level = level
                cached_prefix = prefix
            # Every candidate's squared distance, the photon itself at 0 among them: the
            # (j + 1)-th smallest is the j-th nearest other photon's.
            for c in range(m):
                dx = xs[c] - x
                dy = ys[c] - y
                dz = zs[c] - z
                d2[c] = dx * dx + dy * dy + dz * dz
            # A guess, 1.2 times the photon before's radius (neighbours in Hilbert order
            # have alike radii): the selection reads only the candidates within it when
            # at least j + 1 are.
            guess = GUESS * GUESS * prev * prev if prev >= 0 else np.inf
            inside = 0
            for c in range(m):
                near[inside] = d2[c]  # kept only if it lies within the guess: no branch
                inside += d2[c] < guess
            # np.int64(): one compiled _kth, not a second for the literal 0 that m and
            # inside start from
            if inside > j:
                best = _kth_in_band(near, np.int64(inside), j, prev * prev / (GUESS * GUESS)
                                    if prev >= 0 else 0.0, order)
            elif m > j:
                best = _kth(d2, np.int64(m), j, order)
            else:
                best = np.inf  # fewer than j others in the 27 cubes: the next level up
            cube = step * (2.0 ** (CODE_SHIFT + level))
            side = cube - margin
            if level >= KEY_BITS_PER_AXIS or (side > 0 and best <= side * side):
                break
            level += 1
        out[i] = np.sqrt(best)
        prev = out[i]

