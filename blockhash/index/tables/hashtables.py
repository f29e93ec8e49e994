"""Hash tables of block references (paper sections 4.2 and 4.3).

L tables of ``Px * Py * Pz`` buckets.  A bucket holds up to ``B`` references to
photon blocks (-1 marks an invalid slot), its number of valid entries and its
number of overflows; its priority is ``alpha = |B - entries - overflows|``
(section 4.4): smallest for a bucket that is full but never overflowed.

Insertion (section 4.3):

* every block is inserted into every table once per photon key, never twice
  into one bucket;
* the order is striped across tables (Salem & Garcia-Molina's disk striping,
  Figure 8): in round ``i`` table ``t`` receives block ``(i + t * nblocks // L)
  mod nblocks``, so no block is favoured in every table;
* when a bucket is full, the resident block that sits in the most buckets so
  far is bumped, provided that count is larger than one and larger than the
  incoming block's count; otherwise the incoming reference is dropped and the
  overflow counted.

A block left in no bucket is an *orphan*: its photons can never be found.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

#: Marks an invalid block reference (validity flag off).
NO_BLOCK = -1


@dataclass(frozen=True)
class HashTables:
    """The filled tables.

    Attributes
    ----------
    refs : (L, buckets, B) int32
        Block references; valid ones first in each bucket, ``NO_BLOCK`` after.
    entries : (L, buckets) int32
        Valid references per bucket.
    overflows : (L, buckets) int32
        Insertion attempts made while the bucket was full.
    block_buckets : (nblocks,) int32
        Number of buckets (over all tables) each block is referenced from.
    bumps : int
        References replaced by the bumping rule.
    """

    refs: np.ndarray
    entries: np.ndarray
    overflows: np.ndarray
    block_buckets: np.ndarray
    bumps: int

    @property
    def priority(self) -> np.ndarray:
        """(L, buckets) int32 alpha = |B - entries - overflows| (section 4.4)."""
        B = self.refs.shape[2]
        return np.abs(B - self.entries - self.overflows).astype(np.int32)

    @property
    def orphans(self) -> int:
        """Blocks referenced from no bucket of any table."""
        return int(np.count_nonzero(self.block_buckets == 0))


def insert_blocks(keys, starts, *, buckets: int, B: int) -> HashTables:
    """Insert every block into every table.

    Parameters
    ----------
    keys : (L, n) int64
        Bucket of each photon (in block order) in each table.
    starts : (nblocks + 1,) int64
        Block ``b`` holds photons ``starts[b]:starts[b + 1]`` of the block order.
    buckets : int
        Buckets per table.
    B : int
        References per bucket.
    """
    refs, entries, overflows, counts, bumps = _insert(
        np.ascontiguousarray(keys, dtype=np.int64), np.ascontiguousarray(starts, dtype=np.int64),
        int(buckets), int(B))
    return HashTables(refs=refs, entries=entries, overflows=overflows,
                      block_buckets=counts, bumps=int(bumps))


@numba.njit(cache=True, nogil=True)
def _insert(keys, starts, buckets, B):
    L = keys.shape[0]
    nblocks = starts.shape[0] - 1
    refs = np.full((L, buckets, B), NO_BLOCK, dtype=np.int32)
    entries = np.zeros((L, buckets), dtype=np.int32)
    overflows = np.zeros((L, buckets), dtype=np.int32)
    counts = np.zeros(nblocks, dtype=np.int32)
    stripe = np.empty(L, dtype=np.int64)  # table t starts at block t * nblocks // L
    for t in range(L):
        stripe[t] = (t * nblocks) // L
    longest = 1
    for b in range(nblocks):
        longest = max(longest, starts[b + 1] - starts[b])
    seen = np.empty(longest, dtype=np.int64)
    bumps = 0
    for i in range(nblocks):
        for t in range(L):
            b = i + stripe[t]
            if b >= nblocks:
                b -= nblocks
            nseen = 0  # the block's distinct keys in this table so far
            for s in range(starts[b], starts[b + 1]):
                key = keys[t, s]
                new = True
                for u in range(nseen):
                    if seen[u] == key:
                        new = False
                        break
                if not new:
                    continue
                seen[nseen] = key
                nseen += 1
                e = entries[t, key]
                if e < B:
                    refs[t, key, e] = b
                    entries[t, key] = e + 1
                    counts[b] += 1
                    continue
                overflows[t, key] += 1
                jmax = 0
                cmax = -1
                for j in range(B):
                    c = counts[refs[t, key, j]]
                    if c > cmax:
                        cmax = c
                        jmax = j
                if cmax > 1 and cmax > counts[b]:
                    counts[refs[t, key, jmax]] -= 1
                    refs[t, key, jmax] = b
                    counts[b] += 1
                    bumps += 1
    return refs, entries, overflows, counts, bumps
