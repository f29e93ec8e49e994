"""The cover gather: every photon whose own disc covers a point (the default estimate's query).

The ``conserving`` estimate (blockhash/frame/photon_radius.py) spreads each photon over a disc
of its own radius h_i; a shading point q sums exactly the photons with ``|p_i - q| < h_i``.
That is a fixed-radius question once photons are grouped by radius (Bentley, Stanat and
Williams 1977, the grid of GPU particle systems, here once per radius octave):

* **Octaves.** Cell sides in fixed-point codes (:mod:`.fixedpoint`) grow by ``2^(1/steps)``
  from ``2^MIN_SHIFT`` codes, ``side_l = floor(2^(MIN_SHIFT + l / steps))``, up to a top octave
  of side 2^31 that holds the photons wider than a quarter of the box. A photon goes to the
  first octave whose side is at least ``2 (h_i + margin)``, its radius and the bound on the
  float32 position and query errors (:func:`cover_margin`) in codes.
* **Cells.** Two axes of an octave (the *coarse* axes) are cut into cells of side ``side_l``;
  the third (the *fine* axis) into cells ``FINE`` times thinner, of side ``fine_l =
  ceil(2 half_l / FINE)`` (``half_l = side_l / 2``, saturating; the top octave's is the whole
  box).  The fine axis is the one the photons' surfaces run along most (the smallest mean
  ``|n_a|`` of their stored normals; a floor's photons: x or z), so a column of fine cells follows
  the surface.  Records are sorted by (octave, coarse cell, coarse cell, fine cell), the
  Hilbert order kept within a cell, so the ``FINE + 1`` fine cells of one column that start
  at fine cell ``f`` are one run of records: the *window* (octave, cx, cy, f), stored in a
  cuckoo hash (:func:`.cells.cuckoo_slots`) under :func:`window_key` as (first, count),
  wherever one of its fine cells holds a photon.
* **A query's windows are computed**: at each non-empty octave, on each coarse axis the
  cells that hold ``qcode +- half_l`` (1 or 2), and on the fine axis the window starting at
  the fine cell of ``qcode - half_l``, which holds ``qcode + half_l`` too (``2 half_l <=
  FINE fine_l``): at most 2 x 2 windows.  Every photon of the octave within ``half_l >= h_i +
  margin`` of the query is in them, so every covering photon is found, however the photons
  are spread.  Against 2 x 2 x 2 cubic cells of side ``side_l`` the windows read half the
  cuckoo slots and, on a surface along the fine axis, 5/8 of the candidates.
* **Two dependent rounds** after the keys: the windows' cuckoo slots (2 fetches a window, all
  independent), then their records (independent of each other).  No list is held.
* **Records**, 2 RGBA32UI texels each: the decoded float32 position and the float32 squared
  radius; then the direction toward where the photon came from and its surface normal, each
  as an octahedral unit vector in two snorm16 (:mod:`blockhash.index.records.octahedral`: the shader decodes
  it with no trigonometry, where Figure 4's polar codes need four sines and cosines), and the
  power words of Figure 4 (c1 | c2, c3 | c4).

The bound: a photon of octave l has ``h_i > side_(l-1) / 2 - margin``, so fewer than j other
photons lie within that of it; a window holds O(j) photons of its octave whatever N and the
distribution (the candidates a query reads are measured by ``tools/cover_stats.py``).

:func:`cover_query` is the integer-exact CPU reference of glsl/bh_cover.glsl (keys, cells and
candidates bit for bit; the cover test ``d^2 < h^2`` in float32 as the shader evaluates it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from blockhash.errors import InputError
from blockhash.index.lookups.cells import cuckoo_get, cuckoo_slots
from blockhash.index.lookups.cover_build import gather_records, record_keys, window_entries
from blockhash.index.lookups.cover_keys import window_key
from blockhash.index.records.codec import POLAR_UNIT_VECTORS
from blockhash.index.records.octahedral import octahedral_tables
from blockhash.index.records.radixsort import stable_argsort

#: The finest cell side is 2^MIN_SHIFT codes: coarse cells stay below 2^18 and fine cells
#: below 2^20 (:func:`window_key`).
MIN_SHIFT = 14
#: Fine cells per coarse side on the fine axis (1 to 4: fine cells stay below 2^20); a window
#: is FINE + 1 of them.  Chosen on the ring (2 x 10^5 photons, k = 50, exact radii): 1 reads
#: 7.6x the covering photons, 2 5.7x, 4 4.7x, the stored windows growing about as FINE + 1
#: (``python tools/cover_stats.py --scenes scenes/ring.toml --maps '' --fine 1,2,4
#: --exact-radii``, BENCHMARKS.md, "The cover gather").
FINE = 4
#: The top octave's side: its 2 x 2 cells per axis are the whole box.
TOP_SHIFT = 31
#: Octaves per doubling of the cell side (the octave factor is 2^(1 / steps)).  Tuned on the
#: ring (2 x 10^5 photons, k = 50, exact radii, cubic cells): 1 reads 11.5x the covering
#: photons with 9 octaves, 2 reads 7.6x with 16, 3 reads 6.8x with 23 (``python
#: tools/cover_stats.py --scenes scenes/ring.toml --maps '' --fine 1 --steps 1,2,3
#: --exact-radii``; BENCHMARKS.md, "The cover gather").
OCTAVE_STEPS = 2
#: Octaves a shader holds (uniform arrays of glsl/bh_cover.glsl): steps * 17 + 1 <= this.
MAX_OCTAVES = 64
#: Record words per photon: 2 texels.
RECORD_WORDS = 8


def octave_sides(steps: int = OCTAVE_STEPS) -> np.ndarray:
    """(octaves,) int64 cell side of every octave, in codes: ``floor(2^(MIN_SHIFT + l / steps))``
    below 2^31, then 2^31 (the top octave)."""
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or not 1 <= steps <= 3:
        raise InputError(f"octave steps={steps!r} must be 1, 2 or 3 octaves per doubling of the "
                         "cell side")
    sides = [int(math.floor(2.0 ** (MIN_SHIFT + l / steps)))
             for l in range((TOP_SHIFT - MIN_SHIFT) * int(steps))]
    return np.array(sides + [1 << TOP_SHIFT], dtype=np.int64)


def octave_halves(sides: np.ndarray) -> np.ndarray:
    """(octaves,) uint32 reach of each octave's query: side / 2, the top octave the whole box."""
    halves = (sides // 2).astype(np.uint32)
    halves[-1] = np.uint32(0xFFFFFFFF)
    return halves


def octave_fine(halves: np.ndarray, fine: int = FINE) -> np.ndarray:
    """(octaves,) int64 side of each octave's fine cells: ``ceil(2 half / fine)``, so that a
    window of ``fine + 1`` fine cells holds ``code +- half`` wherever it starts."""
    if isinstance(fine, bool) or not isinstance(fine, (int, np.integer)) or not 1 <= fine <= 4:
        raise InputError(f"fine={fine!r} must be 1, 2, 3 or 4 fine cells per coarse side (the "
                         "window key holds fine cells below 2^20)")
    return -(-2 * halves.astype(np.int64) // int(fine))


def fine_axis(normals: np.ndarray, counts=None) -> int:
    """The axis the photons' surfaces run along most: the smallest mean ``|n_a|`` of their unit
    normals ((n, 3), or a table of them, ``counts`` photons each), x on a floor (first of ties)."""
    if not len(normals) or counts is not None and not np.sum(counts):
        return 0
    return int(np.argmin(np.average(np.abs(np.asarray(normals, np.float64)), axis=0,
                                    weights=counts)))


def axis_order(fine: int) -> tuple[int, int, int]:
    """The code axes as the gather reads them: the two coarse axes, then the fine one."""
    return tuple([a for a in range(3) if a != fine] + [fine])


def cover_margin(quantizer) -> float:
    """Codes added to every radius so that the integer cells hold each photon whose float32
    distance test passes: twice the decode error bound (the photon's decoded position and the
    query's truncated code), plus 2^12 codes for the query's float32 scaling."""
    step = float(np.asarray(quantizer.step, dtype=np.float64).max())
    return 2.0 * float(np.asarray(quantizer.decode_error).max()) / step + 4096.0


@dataclass(frozen=True)
class CoverGather:
    """The cover gather of one photon map (module docstring).

    records : (n, 8) uint32    per record: float32 bits of x, y, z, h^2; octahedral wi and
                               normal; the power words
    photon : (n,) int64        each record's photon, in the caller's order
    octave : (n,) int64        each record's octave
    slots, buckets             the cuckoo table of windows (:func:`.cells.cuckoo_slots`)
    sides, halves              every octave's side and reach (:func:`octave_sides`)
    fines : (octaves,) int64   every octave's fine cell side (:func:`octave_fine`)
    axis : int                 the fine axis (:func:`fine_axis`)
    fine_cells : int           fine cells per coarse side (:data:`FINE`)
    octaves : (m,) int64       the octaves that hold photons, finest first
    max_count : (octaves,) int64  the most records one window of each octave holds
    windows : int              windows stored
    left_out : int             photons with an infinite radius (a map of one photon): they
                               cover nothing at a finite distance and add nothing
    """

    records: np.ndarray
    photon: np.ndarray
    octave: np.ndarray
    slots: np.ndarray
    buckets: int
    sides: np.ndarray
    halves: np.ndarray
    fines: np.ndarray
    axis: int
    fine_cells: int
    octaves: np.ndarray
    max_count: np.ndarray
    windows: int
    left_out: int
    quantizer: object
    power_scale: np.ndarray
    steps: int

    @classmethod
    def build(cls, index, r2, *, steps: int = OCTAVE_STEPS, fine: int = FINE,
              axis: int | None = None) -> "CoverGather":
        """The gather of ``index``'s photons (a :class:`.block_hash_index.BlockHashIndex`:
        its records and quantizer) with squared radii ``r2`` ((n,) in the caller's order,
        float32 steps as :func:`blockhash.frame.photon_radius.own_radii2` gives them);
        ``steps`` octaves per doubling, ``fine`` fine cells per coarse side, ``axis`` the fine
        axis (None: :func:`fine_axis` of the photons' normals)."""
        n = len(index)
        r2 = np.asarray(r2, dtype=np.float64)
        if r2.shape != (n,):
            raise InputError(f"photon radii have shape {r2.shape}; expected ({n},), one per photon")
        bad = np.flatnonzero(np.isnan(r2) | (r2 <= 0))
        if len(bad):
            raise InputError(f"photon radius^2 [{bad[0]}] = {r2[bad[0]]!r}: every photon needs a "
                             "radius > 0 (or inf for none); compute them with own_radii2")
        sides = octave_sides(steps)
        if len(sides) > MAX_OCTAVES:
            raise InputError(f"{len(sides)} octaves > {MAX_OCTAVES} that the cover shader holds")
        q = index.quantizer
        slot_r2 = r2[index.order]                         # in record (Hilbert) order
        kept = np.flatnonzero(np.isfinite(slot_r2))
        halves = octave_halves(sides)
        fines = octave_fine(halves, fine)
        if axis is None:
            codes = (index.records.records[kept, 3] >> 16).astype(np.uint16)  # the normals'
            axis = fine_axis(POLAR_UNIT_VECTORS, np.bincount(codes, minlength=len(POLAR_UNIT_VECTORS)))
        elif axis not in (0, 1, 2):
            raise InputError(f"axis={axis!r} must be 0, 1 or 2 (x, y or z), or None to choose")
        # Each record's octave and its cell's 63-bit key; the keys sorted stably: the Hilbert
        # order stays within each cell (a radix sort, 6x faster than np.lexsort), and the fine
        # cells of a column follow one another.
        codes = index.records.records
        octave, key = record_keys(codes, kept, slot_r2, sides, fines,
                                  np.array(axis_order(axis), dtype=np.int64),
                                  float(np.asarray(q.step, np.float64).max()), cover_margin(q))
        m = len(kept)
        order = stable_argsort(key)
        key, octave, kept, order = key[order], octave[order], kept[order], None
        photon = index.order[kept]
        records = np.empty((m, RECORD_WORDS), dtype=np.uint32)
        gather_records(codes, kept, slot_r2, np.asarray(q.lo, np.float32),
                       np.asarray(q.step, np.float32), *octahedral_tables(), records,
                       records.view(np.float32))
        entries, max_count = window_entries(key, int(fine), len(sides))
        slots, buckets = cuckoo_slots(entries, "cover gather's window table")
        octaves = np.flatnonzero(np.bincount(octave, minlength=len(sides)))
        return cls(records=records, photon=photon.astype(np.int64), octave=octave, slots=slots,
                   buckets=buckets, sides=sides, halves=halves, fines=fines, axis=int(axis),
                   fine_cells=int(fine), octaves=octaves, max_count=max_count,
                   windows=len(entries),
                   left_out=int(n - m), quantizer=q, power_scale=index.records.power_scale,
                   steps=int(steps))

    def __len__(self) -> int:
        return len(self.records)

    @property
    def nbytes(self) -> int:
        """Bytes of the records and the window table."""
        return int(self.records.nbytes + self.slots.nbytes)

    @property
    def table_bytes(self) -> int:
        """Bytes beyond the records: the cuckoo table of windows."""
        return int(self.slots.nbytes)

    def loop_bound(self) -> int:
        """An upper bound on one query's loop iterations in glsl/bh_cover.glsl: per non-empty
        octave its 4 windows, each with at most the octave's fullest window of records, read
        in chunks of 32 (a pass over the chunk, then one over its covering records)."""
        return int(sum(4 * (1 + 2 * self.max_count[o] + -(-self.max_count[o] // 32)) + 1
                       for o in self.octaves))

    def octave_uniforms(self) -> np.ndarray:
        """(m, 4) int64 per non-empty octave, finest first: (octave, side, half, fine side),
        each below 2^32 (the shader's uvec4 uniforms)."""
        o = self.octaves
        return np.stack([o, self.sides[o], self.halves[o].astype(np.int64), self.fines[o]],
                        axis=1)

    def query(self, points) -> "Covering":
        """Every record whose photon's disc covers each of ``points`` ((m, 3), float32)."""
        qpos = np.ascontiguousarray(np.asarray(points, dtype=np.float32).reshape(-1, 3))
        qcodes = np.ascontiguousarray(self.quantizer.quantize_query(qpos)[:, list(axis_order(self.axis))])
        oct_ = self.octave_uniforms()
        recf = self.records.view(np.float32)
        counts, cand, probes = _cover_count(qpos, qcodes, self.slots, np.uint32(self.buckets - 1),
                                            oct_, recf)
        offsets = np.zeros(len(qpos) + 1, dtype=np.int64)
        np.cumsum(counts, out=offsets[1:])
        hits = np.empty(offsets[-1], dtype=np.int64)
        d2 = np.empty(offsets[-1], dtype=np.float32)
        _cover_fill(qpos, qcodes, self.slots, np.uint32(self.buckets - 1), oct_, recf,
                    offsets, hits, d2)
        return Covering(offsets=offsets, records=hits, d2=d2, candidates=cand, probes=probes)


@dataclass(frozen=True)
class Covering:
    """The answer of :meth:`CoverGather.query` for m points, as compressed rows:
    point i's covering records are ``records[offsets[i]:offsets[i + 1]]`` (in the order the
    shader visits them), at squared distances ``d2`` (float32); ``candidates`` (m,) the
    records each point read, ``probes`` (m,) the windows it looked up."""

    offsets: np.ndarray
    records: np.ndarray
    d2: np.ndarray
    candidates: np.ndarray
    probes: np.ndarray

    @property
    def counts(self) -> np.ndarray:
        return np.diff(self.offsets)


@numba.njit(cache=True, nogil=True, inline="always")
def _axis_cells(code, half, side):
    """The first and last cell of one axis that hold ``code +- half``, saturated to the
    codes [0, 2^32) (glsl/bh_cover.glsl's uint arithmetic)."""
    lo = max(np.int64(code) - np.int64(half), np.int64(0))
    hi = min(np.int64(code) + np.int64(half), np.int64(0xFFFFFFFF))
    return lo // np.int64(side), hi // np.int64(side)


@numba.njit(cache=True, nogil=True)
def _visit(qpos, qcodes, slots, mask, octaves, recf, i, offsets, hits, d2s, fill):
    """Covering records of point i (written from offsets[i] when ``fill``): (count, records
    read, windows looked up).
    ``qcodes`` are in :func:`axis_order` (coarse, coarse, fine); ``recf`` is the records'
    float32 view: position and squared radius in words 0-3."""
    qx, qy, qz = qpos[i, 0], qpos[i, 1], qpos[i, 2]
    found = 0
    read = 0
    probes = 0
    for o in range(octaves.shape[0]):
        level, side, half, fine = octaves[o, 0], octaves[o, 1], octaves[o, 2], octaves[o, 3]
        x0, x1 = _axis_cells(qcodes[i, 0], half, side)
        y0, y1 = _axis_cells(qcodes[i, 1], half, side)
        f0, _ = _axis_cells(qcodes[i, 2], half, fine)
        for cx in range(x0, x1 + 1):
            for cy in range(y0, y1 + 1):
                hi, lo = window_key(level, cx, cy, f0)
                first, count = cuckoo_get(slots, mask, hi, lo)
                read += count
                probes += 1
                for r in range(first, first + count):
                    dx = recf[r, 0] - qx
                    dy = recf[r, 1] - qy
                    dz = recf[r, 2] - qz
                    dd = (dx * dx + dy * dy) + dz * dz
                    if dd < recf[r, 3]:
                        if fill:
                            hits[offsets[i] + found] = r
                            d2s[offsets[i] + found] = dd
                        found += 1
    return found, read, probes


@numba.njit(cache=True, nogil=True, parallel=True)
def _cover_count(qpos, qcodes, slots, mask, octaves, recf):
    m = qpos.shape[0]
    counts = np.zeros(m, dtype=np.int64)
    cand = np.zeros(m, dtype=np.int64)
    probes = np.zeros(m, dtype=np.int64)
    dummy_o = np.zeros(1, dtype=np.int64)
    dummy_h = np.zeros(1, dtype=np.int64)
    dummy_d = np.zeros(1, dtype=np.float32)
    for i in numba.prange(m):
        counts[i], cand[i], probes[i] = _visit(qpos, qcodes, slots, mask, octaves, recf, i,
                                               dummy_o, dummy_h, dummy_d, False)
    return counts, cand, probes


@numba.njit(cache=True, nogil=True, parallel=True)
def _cover_fill(qpos, qcodes, slots, mask, octaves, recf, offsets, hits, d2s):
    for i in numba.prange(qpos.shape[0]):
        _visit(qpos, qcodes, slots, mask, octaves, recf, i, offsets, hits, d2s, True)


__all__ = ["CoverGather", "Covering", "octave_sides", "cover_margin", "OCTAVE_STEPS",
           "MAX_OCTAVES", "MIN_SHIFT", "FINE", "fine_axis", "axis_order", "window_key"]
