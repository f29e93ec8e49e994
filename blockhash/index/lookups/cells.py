"""Hilbert cells: the computed hash of ``lookup='cells'`` (a GPU-shaped form of sections 3-4).

Photons are stored in Hilbert order (:mod:`.hilbert`, 21 bits per axis of the 32-bit
codes).  Every cube of the octree over those 21-bit codes is then one contiguous run of
photons: the cell of level ``l`` holding code ``c`` is ``c >> (11 + l)`` on each axis,
and its photons are slots ``first .. first + count - 1``.  One hash table maps
``(level, cell)`` to ``(first, count)``, so a query's bucket at any level is *computed*
from its code and fetched, never searched:

* a cell is stored when its parent holds more than ``min_split`` photons (the top cell,
  the whole box, always), so the table has a few entries per ``min_split`` photons
  whatever the distribution; a cell left out lies in a sparse parent;
* the table is cuckoo hashing at a load of at most 0.4: every key sits in one of the two
  slots its two hash functions name, so a lookup is 2 independent texel fetches and no
  probe sequence.

Levels run from :data:`LEVEL_MIN` (cells of 4 x 4 x 4 Hilbert units, 2^-19 of the box) to
:data:`LEVEL_TOP` (one cell).  The key of a cell packs ``level << 57 | x << 38 | y << 19 |
z`` into two words; :func:`cell_hash` is the 32-bit mix both sides compute
(``glsl/bh_cells.glsl``).  The query is :mod:`.cell_query`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from blockhash.errors import CapacityError

#: Hilbert key bits per axis (:data:`.hilbert.KEY_BITS_PER_AXIS`): cells sit on codes >> 11.
CODE_SHIFT = 11
#: Finest level stored: cells of 2^2 Hilbert units per axis, 19 coordinate bits per axis.
LEVEL_MIN = 2
#: The top level: one cell, the whole box.
LEVEL_TOP = 21
#: Slots per bucket and buckets per key (two hash functions).
SLOTS = 1
CHOICES = 2
#: Word 0 of an empty slot (no real key has its level bits all set).
EMPTY = np.uint32(0xFFFFFFFF)
#: Seeds of the two hash functions.
SEEDS = (0x9E3779B9, 0x7F4A7C15)
#: Cuckoo evictions tried before the table is doubled and built again.
MAX_KICKS = 2000


@numba.njit(cache=True, nogil=True, inline="always")
def fmix32(x):
    """MurmurHash3's 32-bit finaliser, in uint32 arithmetic (GLSL uint wraps the same)."""
    x = np.uint32(x)
    x ^= x >> np.uint32(16)
    x = np.uint32((np.uint64(x) * np.uint64(0x85EBCA6B)) & np.uint64(0xFFFFFFFF))
    x ^= x >> np.uint32(13)
    x = np.uint32((np.uint64(x) * np.uint64(0xC2B2AE35)) & np.uint64(0xFFFFFFFF))
    x ^= x >> np.uint32(16)
    return x


@numba.njit(cache=True, nogil=True, inline="always")
def cell_key(level, cx, cy, cz):
    """The two key words (hi, lo) of cell (cx, cy, cz) of ``level`` (coordinates < 2^19)."""
    lo = np.uint32((np.uint64(cz) | (np.uint64(cy) << np.uint64(19))) & np.uint64(0xFFFFFFFF))
    hi = np.uint32((np.uint64(cy) >> np.uint64(13)) | (np.uint64(cx) << np.uint64(6))
                   | (np.uint64(level) << np.uint64(25)))
    return hi, lo


@numba.njit(cache=True, nogil=True, inline="always")
def cell_hash(hi, lo, seed):
    """Bucket hash of a key: fmix32(lo ^ fmix32(hi ^ seed))."""
    return fmix32(np.uint32(lo) ^ fmix32(np.uint32(hi) ^ np.uint32(seed)))


@dataclass(frozen=True)
class CellTable:
    """The stored cells of one photon map.

    ``slots`` (buckets * 4, 4) uint32: per slot (key hi, key lo, first slot, count), empty
    slots with key hi = 0xFFFFFFFF; ``buckets`` a power of two; ``max_count`` (22,) int64
    the largest count of a stored cell per level (0 where none); ``cells`` entries.
    """

    slots: np.ndarray
    buckets: int
    max_count: np.ndarray
    cells: int
    min_split: int

    @property
    def nbytes(self) -> int:
        return int(self.slots.nbytes)

    def first_level(self, cap: int) -> int:
        """The coarsest level whose stored cells all hold at most ``cap`` photons: a query's
        own cell there is within the cap, so its first round reads only the levels above."""
        for level in range(LEVEL_TOP, LEVEL_MIN - 1, -1):
            if self.max_count[level] <= cap:
                return level
        return LEVEL_MIN


def cell_runs(sorted_codes: np.ndarray, level: int):
    """(starts, counts, coords) of the runs of equal level-``level`` cells of photons in
    Hilbert order: one run per cell."""
    c = (sorted_codes >> np.uint32(CODE_SHIFT + level)).astype(np.uint32)
    change = np.ones(len(c), dtype=bool)
    change[1:] = (c[1:] != c[:-1]).any(axis=1)
    starts = np.flatnonzero(change)
    counts = np.diff(np.append(starts, len(c)))
    return starts, counts, c[starts]


def build_cells(sorted_codes: np.ndarray, *, min_split: int) -> CellTable:
    """The cell table of photons whose (n, 3) uint32 codes are in Hilbert order."""
    n = len(sorted_codes)
    keys_hi, keys_lo, firsts, counts = [], [], [], []
    max_count = np.zeros(LEVEL_TOP + 1, dtype=np.int64)
    parent_starts = np.zeros(1, dtype=np.int64)
    parent_counts = np.array([n], dtype=np.int64)
    for level in range(LEVEL_TOP, LEVEL_MIN - 1, -1):
        starts, cnt, coords = cell_runs(sorted_codes, level)
        if level == LEVEL_TOP:
            keep = np.ones(len(starts), dtype=bool)
        else:
            parent = np.searchsorted(parent_starts, starts, side="right") - 1
            keep = parent_counts[parent] > min_split
        if keep.any():
            max_count[level] = int(cnt[keep].max())
            s, k, xyz = starts[keep], cnt[keep], coords[keep]
            hi, lo = cell_key.py_func(level, xyz[:, 0], xyz[:, 1], xyz[:, 2])  # on arrays
            keys_hi.append(np.asarray(hi, dtype=np.uint32))
            keys_lo.append(np.asarray(lo, dtype=np.uint32))
            firsts.append(s.astype(np.uint32))
            counts.append(k.astype(np.uint32))
        parent_starts, parent_counts = starts, cnt
    entries = np.stack([np.concatenate(keys_hi), np.concatenate(keys_lo),
                        np.concatenate(firsts), np.concatenate(counts)], axis=1)
    slots, buckets = cuckoo_slots(entries, "cell table")
    return CellTable(slots=slots, buckets=buckets, max_count=max_count, cells=len(entries),
                     min_split=int(min_split))


def cuckoo_slots(entries: np.ndarray, what: str) -> tuple[np.ndarray, int]:
    """(slots, buckets): a cuckoo table of ``entries`` ((n, 4) uint32 rows (key hi, key lo,
    value, value), keys distinct, key hi never :data:`EMPTY`) at a load of at most 0.4,
    doubled until every entry sits in one of its two slots; :func:`cell_lookup` and the
    shaders' ``bh_cuckoo`` (glsl/bh_cuckoo.glsl) read it."""
    buckets = 1 << max(0, int(np.ceil(np.log2(max(1, len(entries)) / (SLOTS * 0.4)))))
    while True:
        slots = np.full((buckets * SLOTS, 4), 0, dtype=np.uint32)
        slots[:, 0] = EMPTY
        if _cuckoo_insert(entries, slots, buckets):
            return slots, buckets
        buckets *= 2
        if buckets * SLOTS > 1 << 28:
            raise CapacityError(f"the {what} of {len(entries):,} cells does not fit 2^28 "
                                "slots; this photon map is too large for one index")


@numba.njit(cache=True, nogil=True, inline="always")
def cuckoo_get(slots, mask, hi, lo):
    """(first, count) stored under key (hi, lo), or (0, 0) when it is not stored."""
    for c in range(CHOICES):
        b = cell_hash(hi, lo, SEEDS[c]) & mask
        for s in range(SLOTS):
            i = b * SLOTS + s
            if slots[i, 0] == hi and slots[i, 1] == lo:
                return np.int64(slots[i, 2]), np.int64(slots[i, 3])
    return np.int64(0), np.int64(0)


@numba.njit(cache=True, nogil=True)
def _cuckoo_insert(entries, slots, buckets):
    """Insert every entry into one of the SLOTS slots of its two buckets, evicting as needed;
    False when an insertion fails after MAX_KICKS moves (the caller doubles the table)."""
    # Rows are copied word by word: a row assignment (slots[i] = cur) would compile numba's
    # broadcast checks and their messages, about a second of the first build.
    mask = np.uint32(buckets - 1)
    state = np.uint32(12345)
    width = entries.shape[1]
    cur = np.empty(width, dtype=entries.dtype)
    victim = np.empty(width, dtype=entries.dtype)
    for e in range(entries.shape[0]):
        for w in range(width):
            cur[w] = entries[e, w]
        for kick in range(MAX_KICKS):
            placed = False
            for c in range(CHOICES):
                b = cell_hash(cur[0], cur[1], SEEDS[c]) & mask
                for s in range(SLOTS):
                    i = b * SLOTS + s
                    if slots[i, 0] == EMPTY:
                        for w in range(width):
                            slots[i, w] = cur[w]
                        placed = True
                        break
                if placed:
                    break
            if placed:
                break
            # Evict a pseudo-random slot of one of the two buckets; the evicted entry
            # looks for room in its buckets next.
            state = fmix32(state + np.uint32(kick + 1))
            c = state & np.uint32(1)
            b = cell_hash(cur[0], cur[1], SEEDS[c]) & mask
            i = b * SLOTS + ((state >> np.uint32(1)) & np.uint32(SLOTS - 1))
            for w in range(width):
                victim[w] = slots[i, w]
                slots[i, w] = cur[w]
            cur, victim = victim, cur
        else:
            return False
    return True


@numba.njit(cache=True, nogil=True, inline="always")
def cell_lookup(slots, mask, level, cx, cy, cz):
    """(first, count) of a stored cell, or (0, 0) when the cell is not stored."""
    hi, lo = cell_key(level, cx, cy, cz)
    return cuckoo_get(slots, mask, hi, lo)


__all__ = ["CellTable", "build_cells", "cell_lookup", "cuckoo_slots", "cuckoo_get", "cell_key", "cell_hash", "LEVEL_MIN",
           "LEVEL_TOP", "CODE_SHIFT"]
