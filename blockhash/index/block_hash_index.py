"""The Block Hashing index: build (paper sections 4.1-4.3, 5) and CPU query (4.4).

>>> import numpy as np
>>> from blockhash import BlockHashIndex
>>> pts = np.random.default_rng(0).random((20_000, 3))
>>> index = BlockHashIndex(pts, k=8, A=8)
>>> d, i = index.query(pts[:5])            # like scipy.spatial.cKDTree.query
>>> d.shape, i.shape
((5, 8), (5, 8))

Why this module is long: the index object's build and its two query entry points (the
cKDTree-shaped ``query`` and the oracle's ``reference_query``, which dispatches to each
lookup's CPU reference) share their parameter checks and counters; split, each half would
import the other's private state.
"""

from __future__ import annotations

import functools
import time
import warnings
from dataclasses import dataclass, replace

import numpy as np

from blockhash.errors import InputError
from blockhash.index.lookups.cells import build_cells
from blockhash.index.lookups.cells_query import CELL_ROUNDS, cells_query
from blockhash.index.lookups.hash import bh_query
from blockhash.index.lookups.walk import bf_query, walk_cull
from blockhash.index.records.blocks import BLOCK_WORDS, make_blocks, pack_blocks
from blockhash.index.records.codec import WORDS_PER_PHOTON, PhotonRecords
from blockhash.index.records.hilbert import hilbert_keys
from blockhash.index.tables.adaptive import build_adaptive
from blockhash.index.tables.hashtables import insert_blocks
from blockhash.index.tables.node_boxes import node_boxes
from blockhash.index.tables.params import BlockHashParams, candidate_cap, resolve_params
from blockhash.index.tables.thresholds import ThresholdLayout, build_thresholds, descent_rounds
from blockhash.validate import as_int, as_points, old_keywords

#: Bytes per 32-bit word.
WORD = 4


LOOKUPS = ("cells", "walk", "hash")


def resolve_lookup(params, lookup=None, best_first=None) -> str:
    """The query a call runs: ``lookup`` if given, else 'walk' or 'hash' when ``best_first``
    is given, else the params' (``cells``, then ``best_first``)."""
    if lookup is not None:
        if lookup not in LOOKUPS:
            raise InputError(f"lookup={lookup!r} is not known; choose one of {', '.join(LOOKUPS)}")
        return lookup
    if best_first is not None:
        return "walk" if best_first else "hash"
    if params.cells:
        return "cells"
    return "walk" if params.best_first else "hash"


class OrphanWarning(UserWarning):
    """Some photon blocks are in no hash table: their photons can never be found."""


@dataclass(frozen=True)
class IndexStats:
    """What an index holds and what it costs (paper section 5).

    Counts: ``N`` photons, ``blocks``, ``orphans`` (blocks in no table),
    ``bumps`` (references replaced on overflow), ``overflowing_buckets``
    (buckets that refused or bumped at least once), ``empty_buckets``.
    ``bucket_load`` is the mean fraction of the B slots in use over all buckets.
    Bytes: ``photon_bytes`` (24 N, the records themselves), ``block_bytes`` (256
    per block), ``reference_bytes`` (4 L P^3 B), ``threshold_bytes``,
    ``priority_bytes`` (one word per bucket), ``box_bytes`` (the adaptive tables'
    node boxes, 24 bytes a node), ``cell_bytes`` (the Hilbert cells' cuckoo slots, 16
    bytes a slot) and ``index_bytes`` (the last five).
    ``overhead`` is equation (1) on the real structure: (references + thresholds +
    blocks - photon data) / photon data; ``overhead_with_priority`` adds the
    priority words that the paper's formula leaves out.
    """

    N: int
    blocks: int
    params: BlockHashParams
    orphans: int
    orphan_photons: int
    bumps: int
    overflowing_buckets: int
    empty_buckets: int
    bucket_load: float
    refs_per_photon: float
    used_refs_per_photon: float
    photon_bytes: int
    block_bytes: int
    reference_bytes: int
    threshold_bytes: int
    priority_bytes: int
    box_bytes: int = 0
    cell_bytes: int = 0

    @property
    def index_bytes(self) -> int:
        return (self.reference_bytes + self.threshold_bytes + self.priority_bytes + self.box_bytes
                + self.cell_bytes)

    @property
    def overhead(self) -> float:
        """Equation (1) measured: (refs + thresholds + node boxes + blocks - 24 N) / 24 N."""
        return (self.reference_bytes + self.threshold_bytes + self.box_bytes + self.block_bytes
                - self.photon_bytes) / self.photon_bytes

    @property
    def overhead_with_priority(self) -> float:
        return self.overhead + self.priority_bytes / self.photon_bytes

    def summary(self) -> str:
        """A few lines for people."""
        p = self.params
        lines = [
            f"{p!r}",
            f"photons {self.N:,} in {self.blocks:,} blocks; buckets {p.L} x {p.buckets:,} x B={p.B}",
            f"orphans {self.orphans:,} blocks ({self.orphan_photons:,} photons), bumps {self.bumps:,}, "
            f"overflowing buckets {self.overflowing_buckets:,}, empty buckets {self.empty_buckets:,}",
            f"bucket load {self.bucket_load:.1%}; block references per photon "
            f"{self.refs_per_photon:.2f} allocated, {self.used_refs_per_photon:.2f} used",
            f"memory: photon blocks {self.block_bytes / 2**20:.1f} MiB, index "
            f"{self.index_bytes / 2**20:.1f} MiB (cells {self.cell_bytes / 2**20:.1f} MiB); "
            f"overhead (eq. 1) {self.overhead:.1%}",
        ]
        if self.orphans:
            lines.insert(0, f"WARNING: {self.orphans:,} orphaned blocks: {self.orphan_photons:,} "
                            "photons can never be found")
        return "\n".join(lines)


#: :meth:`BlockHashIndex.reference_query`'s switches, beyond the cKDTree-shaped query.
ORACLE_SWITCHES = ("by_priority", "slot_bits", "probe", "best_first", "walk_trees")


class BlockHashIndex:
    """Approximate k-nearest-photon search by Block Hashing.

    Parameters
    ----------
    positions : (n, 3) float
        Photon positions, finite, n >= 1.
    k : int, keyword-only
        Neighbours per query the index is built for (1 <= k <= n).
    A : int, keyword-only
        Accuracy multiplier: a query examines about ``A * k`` candidates (>= 1).
    preset : {'default', 'paper'}
        Parameter choice, see :mod:`blockhash.index.tables.params`.
    L, P, B : int, optional
        Override the preset's tables, buckets per axis (one int or three), refs per bucket.
    layout : {'adaptive', 'marginal'}, optional
        Override the preset's threshold layout (``marginal``: the paper's grid, with the
        preset's buckets per table unless P is given).
    builder : {'bulk', 'btree'}
        Block builder (section 4.1); both give the same blocks.
    directions, normals : (n, 3) float unit vectors, optional
    powers : (n, 3) or (n, 4) float watts, optional
        Photon payload stored in the records (Figure 4).
    tables : bool
        False: build only the records in Hilbert order now (what the cover gather and the
        photon radii read), and the hash tables, node boxes, packed blocks and ``stats`` on
        their first use (``tables_built`` says which).

    Block hashing gives no (1 + eps) guarantee on distances; measure recall and
    dilation with :mod:`blockhash.evaluate.metrics`.
    """

    def __init__(self, positions, *, k: int = 50, A: int = 8, preset: str = "default",
                 L=None, P=None, B=None, layout=None, builder: str = "bulk",
                 directions=None, normals=None, powers=None, tables: bool = True):
        # float32 photons (a traced map's) are read as they are, not copied to float64
        pos = as_points(positions, "positions", allow_empty=False, dtype=np.float32 if getattr(
            positions, "dtype", None) == np.float32 else np.float64)
        timings = {}
        t0 = time.perf_counter()
        self.params = resolve_params(pos, k=k, A=A, preset=preset, L=L, P=P, B=B, layout=layout)
        records = PhotonRecords.encode(pos, directions=directions, normals=normals, powers=powers)
        codes = records.records[:, :3]
        t1 = time.perf_counter()
        timings["encode"] = t1 - t0
        leaves = make_blocks(hilbert_keys(codes), builder=builder)
        t2 = time.perf_counter()
        timings["blocks"] = t2 - t1
        self.order = leaves.order
        self.starts = leaves.starts
        sorted_records = np.take(records.records, self.order, axis=0)  # 3x faster than [order]
        self.records = PhotonRecords._own(sorted_records, records.quantizer, records.power_scale)
        self.quantizer = records.quantizer
        del records, codes, leaves, pos  # the input order's records go before the positions come
        self._cells = None
        self.counters: dict[str, float] = {}
        timings["total"] = time.perf_counter() - t0
        self.timings = timings
        self._tables_built = False
        if tables:
            self._build_tables()

    #: What :meth:`_build_tables` makes (an index built with ``tables=False`` makes it on the
    #: first use of any of these).
    _TABLE_ATTRS = frozenset({"thresholds", "tables", "priority", "block_words", "node_boxes",
                              "stats"})

    def __getattr__(self, name):
        if name == "_positions":  # (n, 3) float32 decoded positions in Hilbert order, on use
            # (the cover gather decodes its records itself: a render's index never holds them)
            self._positions = self.quantizer.decode(np.ascontiguousarray(self.records.records[:, :3]))
            return self._positions
        if name in BlockHashIndex._TABLE_ATTRS and not self.__dict__.get("_tables_built", True):
            self._build_tables()
            return getattr(self, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def tables_built(self) -> bool:
        """Whether the hash tables exist (built eagerly unless ``tables=False``)."""
        return self._tables_built

    def _build_tables(self) -> None:
        """The hash tables, their node boxes and the packed blocks (sections 4.2-4.3), and the
        stats; warns about orphan blocks."""
        self._tables_built = True
        timings = self.timings
        t2 = time.perf_counter()
        sorted_records = self.records.records
        sorted_codes = np.ascontiguousarray(sorted_records[:, :3])
        prm = self.params
        if prm.layout == ThresholdLayout.ADAPTIVE:
            self.thresholds, photon_keys, buckets = build_adaptive(
                sorted_codes, L=prm.L, photons_per_bucket=prm.bucket_photons,
                scale=self.quantizer.step)
            self.params = prm = replace(prm, adaptive_buckets=buckets)
        else:
            self.thresholds, photon_keys = build_thresholds(sorted_codes, prm.P, prm.L, prm.layout)
        t3 = time.perf_counter()
        timings["thresholds"] = t3 - t2
        self.tables = insert_blocks(photon_keys, self.starts, buckets=prm.buckets, B=prm.B)
        self.priority = self.tables.priority
        t4 = time.perf_counter()
        timings["insert"] = t4 - t3
        self.block_words = pack_blocks(sorted_records, self.starts)
        t5 = time.perf_counter()
        timings["pack"] = t5 - t4
        #: (L, nodes, 6) float32 node boxes of the adaptive tables (None for a grid layout).
        self.node_boxes = None
        if prm.layout == ThresholdLayout.ADAPTIVE:
            self.node_boxes = node_boxes(self.thresholds, photon_keys, self._positions, prm.buckets)
        timings["boxes"] = time.perf_counter() - t5
        timings["total"] = timings["total"] + time.perf_counter() - t2
        self.stats = self._stats()
        if prm.cells:  # an index built to query its cells has them from the start
            self._build_cells()
        if self.stats.orphans:
            fix = ("raise B or L, or use preset='default'" if prm.layout != ThresholdLayout.ADAPTIVE
                   else "a bucket holds more blocks than its B references (photons at one "
                        "position make one bucket that no cut splits): raise A (buckets grow "
                        "with it) or B")
            warnings.warn(
                f"{self.stats.orphans:,} of {self.stats.blocks:,} photon blocks "
                f"({self.stats.orphan_photons:,} photons) are in no hash table and can never be "
                f"found with {prm!r}; {fix}", OrphanWarning, stacklevel=3)

    def __len__(self) -> int:
        return len(self.order)

    def __repr__(self) -> str:
        return f"BlockHashIndex(N={len(self):,}, blocks={self.stats.blocks:,}, {self.params!r})"

    @functools.cached_property
    def slot_of(self) -> np.ndarray:
        """(n,) int64 position in block order of each photon (the inverse of ``order``)."""
        slots = np.empty(len(self.order), dtype=np.int64)
        slots[self.order] = np.arange(len(self.order))
        return slots

    @property
    def positions(self) -> np.ndarray:
        """(n, 3) float32 decoded photon positions in the caller's order."""
        out = np.empty_like(self._positions)
        out[self.order] = self._positions
        return out

    def _stats(self) -> IndexStats:
        prm = self.params
        t = self.tables
        n = len(self.order)
        nblocks = len(self.starts) - 1
        sizes = np.diff(self.starts)
        orphan = t.block_buckets == 0
        return IndexStats(
            N=n, blocks=nblocks, params=prm,
            orphans=int(orphan.sum()), orphan_photons=int(sizes[orphan].sum()),
            bumps=t.bumps, overflowing_buckets=int(np.count_nonzero(t.overflows)),
            empty_buckets=int(np.count_nonzero(t.entries == 0)),
            bucket_load=float(t.entries.mean() / prm.B),
            refs_per_photon=prm.refs / n, used_refs_per_photon=float(t.entries.sum()) / n,
            photon_bytes=n * WORDS_PER_PHOTON * WORD, block_bytes=nblocks * BLOCK_WORDS * WORD,
            reference_bytes=prm.refs * WORD, threshold_bytes=self.thresholds.size * WORD,
            priority_bytes=prm.L * prm.buckets * WORD,
            cell_bytes=0 if self._cells is None else self._cells.nbytes,
            box_bytes=0 if self.node_boxes is None else self.node_boxes.nbytes)

    @property
    def cells(self):
        """The Hilbert cells (:mod:`.cells`) that ``lookup='cells'`` reads: built on first
        use (half the build time of the rest of the index at 10^6 photons, which the walk and
        the hashing never read); ``stats.cell_bytes`` counts them from then on."""
        if self._cells is None:
            self._build_cells()
        return self._cells

    def _build_cells(self) -> None:
        t = time.perf_counter()
        self._cells = build_cells(self.records.records[:, :3],  # the codes, in Hilbert order
                                  min_split=max(1, self.params.k // 8))
        self.timings["cells"] = time.perf_counter() - t
        self.stats = replace(self.stats, cell_bytes=self._cells.nbytes)

    def query(self, points, k=None, *, A=None, lookup: str | None = None, **oracle):
        """Approximate k nearest photons, like ``scipy.spatial.cKDTree.query``.

        ``points``, ``k``, ``A`` and ``lookup`` are as in :meth:`reference_query`, which
        returns the same ``(distances, indices)``.  The oracle switches (``by_priority``,
        ``slot_bits``, ``probe``, ``best_first``, ``walk_trees``) still work here and warn
        (DeprecationWarning): they belong to :meth:`reference_query`.
        """
        old_keywords("BlockHashIndex.query", oracle, ORACLE_SWITCHES,
                     "the oracle switches belong to BlockHashIndex.reference_query")
        return self.reference_query(points, k, A=A, lookup=lookup, **oracle)

    def reference_query(self, points, k=None, *, A=None, by_priority: bool = True,
                        slot_bits: int = 0, probe: bool | None = None,
                        best_first: bool | None = None, walk_trees: int | None = None,
                        lookup: str | None = None):
        """The CPU reference of every lookup and shader variant, the oracle the GL side is
        tested against: :meth:`query` with the switches that reproduce each variant.

        Parameters
        ----------
        points : (m, 3) or (3,) float
            Query points.  Rows with NaN or inf get no neighbours (distance inf,
            index N), as the shader returns for a background pixel; so do neighbours
            whose float32 squared distance overflows (queries ~1.8e19 m away).
        k : int, optional
            Neighbours per query, 1 <= k <= N (default: the k the index was built for).
        A : int, optional
            Accuracy multiplier for this query (default: the index's A).
        by_priority : bool
            Visit buckets by priority alpha (section 4.4); False visits them in
            table order, as the shader variant with priority 'off' does.
        slot_bits : int
            0 (default) selects by exact distance.  The shader's 'packed' selection
            variant compares distances with their low ``slot_bits`` bits replaced by
            the candidate's number; passing its value
            (``gl.lookup.query_slot_bits(params, k, A)``) reproduces that variant exactly.  Neighbours then differ from the exact
            selection only where squared distances agree to 2**-(23 - slot_bits).
        probe : bool, optional
            Multi-probe beyond the query's own buckets while the cap allows
            (:mod:`blockhash.index.lookups.hash`); default: the preset's (on for 'default').
        best_first : bool, optional
            Walk the adaptive tables' node boxes nearest first
            (:mod:`blockhash.index.lookups.walk`) instead of hashing (and probing);
            default: the preset's (on for 'default').  ``by_priority`` and ``probe``
            do not change this walk.
        walk_trees : int, optional
            Tables the walk is seeded with (1 .. L, more is L); default: the
            params' ``walk_trees`` (1 for 'default').
        lookup : {'cells', 'walk', 'hash'}, optional
            The query: the Hilbert cells (:mod:`blockhash.index.lookups.cells_query`), the tables'
            nearest-box-first walk (the default preset's), or their hash query;
            default: the params' (``cells``, else ``best_first``).  ``best_first`` given
            alone chooses between the last two.

        Returns
        -------
        distances : (m, k) float64, ascending; inf where fewer than k were found
        indices : (m, k) int64 into the build positions; N where fewer than k were found
            As with cKDTree, an integer k == 1 drops the last axis and a single
            (3,) point drops the first.
        """
        n = len(self)
        k_eff = self.params.k if k is None else as_int(
            k, "k", minimum=1, maximum=n, hint=f"use k <= N={n:,} or add photons")
        A_eff = self.params.A if A is None else as_int(A, "A", minimum=1)
        arr = np.asarray(points)
        single = arr.ndim == 1
        q = as_points(arr.reshape(1, -1) if single else arr, "points", dtype=np.float32, finite=False)
        finite = np.isfinite(q).all(axis=1)
        qf = np.where(finite[:, None], q, np.float32(0.0))
        prm = self.params
        lookup = resolve_lookup(prm, lookup, best_first)
        walk = lookup == "walk"
        if walk and self.node_boxes is None:
            raise InputError(f"best_first=True needs the adaptive layout's node boxes; this index "
                             f"has the {prm.layout.name.lower()} layout: build it with "
                             "layout='adaptive' (the default preset) or query with best_first=False")
        extra = {}
        if lookup == "cells":
            cap = A_eff * k_eff
            d2, slots, examined, fetched = cells_query(
                self.quantizer.quantize_query(qf), qf, self.cells.slots, self.cells.buckets,
                self.cells.first_level(cap), self._positions, k_eff, cap)
            extra = {"query.rounds.mean": float(CELL_ROUNDS) if finite.any() else 0.0,
                     "query.rounds.max": float(CELL_ROUNDS) if finite.any() else 0.0}
        elif walk:
            trees = prm.walk_tables(k_eff) if walk_trees is None else min(
                as_int(walk_trees, "walk_trees", minimum=1), prm.L)
            d2, slots, examined, fetched, pops, drops, longest = bf_query(
                qf, self.thresholds, self.node_boxes, self.tables.refs, self.starts,
                self._positions, k_eff, candidate_cap(prm, k_eff, A_eff), slot_bits,
                trees=trees, cull=walk_cull(self))
            if finite.any():
                # Each pop waits on the box the previous pop fetched; the last leaf's
                # references and blocks add two rounds (a lower bound: leaves met on the
                # way add theirs between pops).
                extra = {"query.rounds.mean": float(pops[finite].mean()) + 2.0,
                         "query.rounds.max": float(pops[finite].max()) + 2.0,
                         "query.pops.mean": float(pops[finite].mean()),
                         "query.pops.max": float(pops[finite].max()),
                         "query.queue.max": float(longest[finite].max()),
                         "query.queue_drops.sum": float(drops[finite].sum())}
        else:
            codes = self.quantizer.quantize_query(qf)
            d2, slots, examined, fetched = bh_query(
                codes, qf, self.thresholds,
                np.asarray(prm.P, dtype=np.int64), int(prm.layout), self.tables.refs,
                self.priority, self.starts, self._positions, k_eff, A_eff * k_eff, by_priority,
                slot_bits, prm.probe if probe is None else bool(probe),
                self.quantizer.step.astype(np.float32))
            if finite.any():
                # The tables descend side by side; the buckets' references and then their
                # blocks add two rounds (a lower bound: multi-probe descends again below a
                # cut, and its blocks follow).
                rounds = descent_rounds(self.thresholds, int(prm.layout), codes[finite]) + 2
                extra = {"query.rounds.mean": float(rounds.mean()),
                         "query.rounds.max": float(rounds.max())}
        d2[~finite] = np.inf
        slots[~finite] = -1
        self.counters = {
            "query.points": float(len(q)),
            "query.candidates.mean": float(examined[finite].mean()) if finite.any() else 0.0,
            "query.blocks.mean": float(fetched[finite].mean()) if finite.any() else 0.0,
            **extra,
        }
        distances = np.sqrt(d2.astype(np.float64))
        # A squared distance that overflows float32 (a query ~1.8e19 m away) orders
        # nothing: report that neighbour as missing, like the shader's caller does.
        indices = np.where((slots >= 0) & np.isfinite(d2), self.order[np.maximum(slots, 0)], n)
        if single:
            distances, indices = distances[0], indices[0]
        if k is not None and not isinstance(k, (list, tuple, np.ndarray)) and k_eff == 1:
            distances, indices = distances[..., 0], indices[..., 0]
        return distances, indices


__all__ = ["BlockHashIndex", "IndexStats", "OrphanWarning"]
