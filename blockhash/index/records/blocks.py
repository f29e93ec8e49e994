"""64-word photon blocks (paper sections 3.2 and 4.1).

A block is 64 32-bit words: up to ten 6-word photon records in words 0-59,
then the spare words, of which word 60 holds the number of photons stored
(the paper keeps the count there) and words 61-63 are zero.  Photons are
ordered along a 3D Hilbert curve and cut into blocks by one of two builders
(:mod:`blockhash.index.records.btree`): a real B+-tree with leaf compaction, or the compact
static B+-tree bulk build for a known photon set.  Both leave disjoint blocks
each covering a compact interval of the curve (Figure 7a).
"""

from __future__ import annotations

import numpy as np

from blockhash.errors import InputError
from blockhash.index.records.btree import LeafBlocks, btree_blocks, bulk_blocks
from blockhash.index.records.codec import WORDS_PER_PHOTON

#: Words per block: a 64-word burst (section 3.2).
BLOCK_WORDS = 64
#: Records per block: floor(64 / 6) = 10.
PHOTONS_PER_BLOCK = BLOCK_WORDS // WORDS_PER_PHOTON
#: Word of a block holding its photon count.
COUNT_WORD = PHOTONS_PER_BLOCK * WORDS_PER_PHOTON
BUILDERS = ("bulk", "btree")


def make_blocks(keys, *, builder: str = "bulk") -> LeafBlocks:
    """Cut photons ordered by Hilbert key into blocks with the chosen builder.

    Parameters
    ----------
    keys : (n,) uint64 Hilbert keys
    builder : {'bulk', 'btree'}
    """
    if builder == "bulk":
        return bulk_blocks(keys, leaf_capacity=PHOTONS_PER_BLOCK)
    if builder == "btree":
        return btree_blocks(keys, leaf_capacity=PHOTONS_PER_BLOCK)
    raise InputError(f"builder={builder!r} is not known; choose one of {', '.join(BUILDERS)}")


def block_boxes(block_words: np.ndarray) -> np.ndarray:
    """(nblocks, 3) uint32: per axis, the top 16 bits of the block's smallest and largest
    photon code, ``lo16 | hi16 << 16``: every photon code u of the block has
    ``lo16 << 16 <= u <= hi16 << 16 | 0xFFFF``.  The GL upload (blockhash/gl/packing.py)
    puts them in the spare words 61-63, which the index leaves zero, in the same texel as
    the photon count: the lookup's block culling (BH_CULL, and the walk's, glsl/bh_blocks.glsl
    bh_block_gap2) reads them there; the CPU walk (blockhash/index/lookups/walk.py) computes the
    same bound from them.
    """
    w = np.asarray(block_words, dtype=np.uint32)
    nb = len(w)
    codes = w[:, :COUNT_WORD].reshape(nb, PHOTONS_PER_BLOCK, WORDS_PER_PHOTON)[:, :, :3]
    valid = (np.arange(PHOTONS_PER_BLOCK)[None, :] < w[:, COUNT_WORD, None])[:, :, None]
    lo = np.where(valid, codes, np.uint32(0xFFFFFFFF)).min(axis=1) >> np.uint32(16)
    hi = np.where(valid, codes, np.uint32(0)).max(axis=1) >> np.uint32(16)
    return (lo | (hi << np.uint32(16))).astype(np.uint32)


def pack_blocks(records: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Photon records in block order -> (nblocks, 64) uint32 block words.

    Parameters
    ----------
    records : (n, 6) uint32, photons in block order
    starts : (nblocks + 1,) int64, block b holds records[starts[b]:starts[b + 1]]
    """
    records = np.asarray(records)
    starts = np.asarray(starts, dtype=np.int64)
    if records.ndim != 2 or records.shape[1] != WORDS_PER_PHOTON or records.dtype != np.uint32:
        raise InputError(f"records must be a (n, {WORDS_PER_PHOTON}) uint32 array; got shape "
                         f"{records.shape}, dtype {records.dtype}")
    if starts.ndim != 1 or len(starts) < 1 or starts[0] != 0 or starts[-1] != len(records):
        raise InputError(f"starts must run from 0 to len(records)={len(records)}; got "
                         f"{starts[:1].tolist()}..{starts[-1:].tolist()}")
    counts = np.diff(starts)
    if counts.size and (counts.min() < 1 or counts.max() > PHOTONS_PER_BLOCK):
        raise InputError(f"block sizes must be 1..{PHOTONS_PER_BLOCK}; got {counts.min()}..{counts.max()}")
    nblocks = len(counts)
    words = np.zeros((nblocks, BLOCK_WORDS), dtype=np.uint32)
    view = words[:, :COUNT_WORD].reshape(nblocks, PHOTONS_PER_BLOCK, WORDS_PER_PHOTON)
    full = nblocks - 1
    if nblocks and (counts[:full] == PHOTONS_PER_BLOCK).all():
        # Full blocks but the last (the bulk build's): the records are the blocks' rows.
        view[:full] = records[:full * PHOTONS_PER_BLOCK].reshape(full, PHOTONS_PER_BLOCK,
                                                                  WORDS_PER_PHOTON)
        view[full, :counts[full]] = records[full * PHOTONS_PER_BLOCK:]
    else:
        block = np.repeat(np.arange(nblocks), counts)
        slot = np.arange(len(records)) - np.repeat(starts[:-1], counts)
        view[block, slot] = records
    words[:, COUNT_WORD] = counts
    return words


def unpack_blocks(words: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(nblocks, 64) block words -> (records (n, 6) uint32, starts (nblocks + 1,) int64)."""
    counts = words[:, COUNT_WORD].astype(np.int64)
    if counts.size and counts.max() > PHOTONS_PER_BLOCK:
        b = int(np.argmax(counts))
        raise InputError(f"block {b} has count word {counts[b]} > {PHOTONS_PER_BLOCK}; "
                         "these are not blocks written by pack_blocks")
    view = words[:, :COUNT_WORD].reshape(len(words), PHOTONS_PER_BLOCK, WORDS_PER_PHOTON)
    mask = np.arange(PHOTONS_PER_BLOCK)[None, :] < counts[:, None]
    starts = np.concatenate([[0], np.cumsum(counts)])
    return view[mask], starts
