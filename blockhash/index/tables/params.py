"""Block Hashing parameters and their presets (paper section 5).

``BlockHashParams`` holds k, A, L, P (buckets per axis, grid layouts) and B.
Two presets choose them:

``paper``
    Exactly section 5: ``L = P = round(ln N)`` on every axis and
    ``B = ceil(A k / (10 L))``, marginal thresholds, buckets visited by priority
    alpha, no probing.  Kept so that the paper's figures can be reproduced.
    ``P = ln N`` grows much more slowly than the ``(N / k)^(1/3)`` that puts
    about k photons in a bucket, so accuracy falls as N grows, and on a planar
    caustic only ``P^2`` of the ``P^3`` buckets are live.

``default``
    The adaptive layout (:mod:`blockhash.index.tables.adaptive`): each table a kd-tree
    of count thresholds with buckets of ``S`` photons on whatever surfaces the
    photons lie; a query walks the tight node boxes of the first ``walk_trees``
    tables (one) nearest first, under the ``A k`` candidate cap alone
    (:mod:`blockhash.index.lookups.walk`; ``best_first=False`` at query time gives
    the hash query instead: buckets visited deepest first and multi-probed across
    their nearest borders, :mod:`blockhash.index.lookups.hash`).  ``lookup='cells'`` at query
    time (or ``cells=True`` in the params, for the shaders) reads the Hilbert cells
    instead (:mod:`blockhash.index.lookups.cells`): a computed hash of octree cells, three
    rounds of independent fetches, no tree descent and no queue; not the default
    while it misses queries far from every photon (BENCHMARKS.md).  A is the one knob:
    ``S = DEFAULT_PHOTONS_PER_BUCKET * k * A / ADAPTIVE_REFERENCE_A`` grows with
    the candidate budget ``A k``, and ``B`` with ``S``, so the memory per photon
    stays about ``L B / S`` at every A.

Constants were chosen with ``tools/eval_accuracy.py`` on its TUNE photon maps
(uniform, clustered, caustic, the ring scene's) and are reported on maps that
chose nothing (BENCHMARKS.md).  Every parameter can be overridden by keyword.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from blockhash.errors import CapacityError, InputError
from blockhash.index.records.blocks import PHOTONS_PER_BLOCK
from blockhash.index.tables.thresholds import RETIRED_LAYOUTS, ThresholdLayout
from blockhash.validate import as_int

PRESETS = ("default", "paper")
#: Upper limits that keep the tables addressable and the shader's arrays small.
MAX_L = 64
MAX_P = 4096
MAX_B = 256
#: Block references allowed in the whole index: 2**28 refs is 1 GiB of int32.
MAX_REFS = 1 << 28

#: Default preset, measured with tools/eval_accuracy.py on its TUNE maps only (uniform,
#: clustered, caustic, the ring scene's; N = 3 x 10^5, k = 50, 6,000 queries, A = 8):
#:
#:     python tools/eval_accuracy.py --tune --photons 3e5 --queries 6000 --A 8 \
#:         --presets default --ppb 0.5,0.75,1,1.5 --L 5,7,9
#:     python tools/eval_accuracy.py --tune --photons 3e5 --queries 6000 --A 1,8,64 \
#:         --presets default --ppb 0.25,0.35,0.5 --L 5
#:
#: Photons per bucket, as a multiple of k at A = ADAPTIVE_REFERENCE_A.  Mean false negatives
#: at L = 5 fell with smaller buckets, uniform / clustered / caustic / ring: 3.7 / 31.8 / 3.2
#: / 8.7% at 1.5, 2.1 / 29.8 / 1.9 / 7.3% at 1, 1.2 / 28.1 / 1.2 / 6.8% at 0.75, 0.5 / 26.0
#: / 0.7 / 6.3% at 0.5; at 0.35 and 0.25 buckets of two or three blocks leave the budget
#: unspent (caustic examined 256 and 188 of 400 candidates) and uniform and ring get no
#: better or worse (1.5 / 8.4% at 0.25).  Smaller buckets are visited in more tables and
#: probes; the A k budget is then spent nearer the query.
DEFAULT_PHOTONS_PER_BUCKET = 0.5
#: The A at which the default preset's buckets hold DEFAULT_PHOTONS_PER_BUCKET * k photons;
#: they grow in proportion to A, so that the buckets a query visits hold about its A * k
#: candidates (the paper's B = ceil(A k / 10 L) rule, with the buckets sized instead).
ADAPTIVE_REFERENCE_A = 8
#: Tables.  With probing, more tables change little (same runs, ppb 0.5: L = 5, 7, 9 give
#: 0.46 / 0.39 / 0.51% on uniform, 26.0 / 25.4 / 25.3% on clustered, 0.73 / 0.72 / 0.74% on
#: caustic, 6.3 / 6.4 / 6.3% on ring), and the build and the memory grow with L: 5.
DEFAULT_L = 5
#: Tables the default preset's nearest-box-first walk is seeded with: 1.  All five miss
#: fewer neighbours, in 4-5x the pops and rounds of dependent fetches; one keeps every map
#: within the A = 8 target with the shortest chain (BENCHMARKS.md, "The walk over one tree
#: or all five", N = 10^6, k = 50).
DEFAULT_WALK_TREES = 1
#: The default preset's walk examines at least A * DEFAULT_WALK_FLOOR candidates, and walks
#: all L tables, for k below it.  With the A k cap alone a query for k = 1 at A = 8 takes
#: 8 candidates, less than one block, and missed 72-82% of the nearest neighbours on every
#: map (tools/accuracy_by_k.py); a quarter of the photons' blocks are also missing from
#: their own bucket in the one table walked (its buckets overflow), which 98.7% of the
#: misses at k = 1, A = 64 came from.  Chosen on the TUNE maps (`python tools/small_k.py`,
#: A = 8): at k = 1 clustered missed 82.3% with no floor, 20.8% with a floor of 20 over one
#: table and 0.75% over all five (uniform 81.9 / 9.2 / 0.12%); a floor of 10 over all
#: tables still missed 15% at k = 8; 20 over all tables at most 3.0% for k <= 16: 20.
DEFAULT_WALK_FLOOR = 20
#: A memory bound on block references per photon (the index issue's target is 2.5).
DEFAULT_REFS_PER_PHOTON = 2.4
#: B holds up to this many times the blocks that a bucket's photons fill.  Blocks straddle
#: bucket borders: a bucket of S photons touches a median 2.4 S / 10 blocks at S = 25 and
#: 1.5 S / 10 at S = 200 on the caustic map, so small buckets overflow (the slot of a block
#: that sits in more buckets is given up first, section 4.3).  --slack 3,5 (same maps, A = 1,
#: 8, 64) changed mean false negatives by at most 0.9 points, at 1.5-1.6 against 2.0-2.4
#: references per photon: 3.
DEFAULT_BLOCK_SLACK = 3.0
@dataclass(frozen=True)
class BlockHashParams:
    """Parameters of a block hashing index.

    Attributes
    ----------
    k : int           neighbours sought per query (>= 1)
    A : int           accuracy multiplier: a query examines about A * k photons (>= 1)
    L : int           hash tables
    P : (int, int, int) buckets per axis (x, y, z); a table has Px * Py * Pz buckets
    B : int           block references per bucket
    layout : ThresholdLayout  marginal (the paper's grid) or adaptive (kd-tree rows)
    preset : str      where the values came from
    """

    k: int
    A: int
    L: int
    P: tuple[int, int, int]
    B: int
    layout: ThresholdLayout = ThresholdLayout.MARGINAL
    preset: str = "custom"
    #: ADAPTIVE layout only: target photons per bucket, and the buckets per table that
    #: the build made (0 until then).
    bucket_photons: float = 0.0
    adaptive_buckets: int = 0
    #: Multi-probe the buckets beyond the query's own when the candidate cap allows
    #: (:mod:`blockhash.index.lookups.hash`, step 4).
    probe: bool = False
    #: ADAPTIVE layout only: walk the tables' node boxes nearest first
    #: (:mod:`blockhash.index.lookups.walk`) instead of hashing and probing.
    best_first: bool = False
    #: The walk's tables: it is seeded with the roots of the first ``walk_trees``
    #: (1 .. L; L or more walks all of them).
    walk_trees: int = 1
    #: Query the Hilbert cells (:mod:`blockhash.index.lookups.cells`, three rounds of independent
    #: fetches, selection by counting) instead of the tables.
    cells: bool = False
    #: The walk's small-k floor: for k below it the walk examines up to A * walk_floor
    #: candidates (not A * k) over all L tables (0: none, the A k cap alone).
    walk_floor: int = 0

    def __post_init__(self):
        if int(self.walk_trees) < 1:
            raise InputError(f"walk_trees={self.walk_trees!r} must be >= 1 (the tables the "
                             f"nearest-box-first walk is seeded with; {self.L} walks all)")

    @property
    def trees_walked(self) -> int:
        """The tables the nearest-box-first walk is seeded with, ``min(walk_trees, L)``."""
        return min(int(self.walk_trees), self.L)

    def walk_tables(self, k: int) -> int:
        """Tables the walk is seeded with for k neighbours: all L below ``walk_floor``,
        else :attr:`trees_walked`."""
        return self.L if k < self.walk_floor else self.trees_walked

    @property
    def buckets(self) -> int:
        """Buckets per table (ADAPTIVE: as built, or estimated from N before the build)."""
        if self.layout == ThresholdLayout.ADAPTIVE:
            return self.adaptive_buckets
        return self.P[0] * self.P[1] * self.P[2]

    @property
    def refs(self) -> int:
        """Block reference slots in the whole index, L * buckets * B."""
        return self.L * self.buckets * self.B

    def __repr__(self) -> str:
        px, py, pz = self.P
        if self.layout == ThresholdLayout.ADAPTIVE:
            built = f", buckets={self.adaptive_buckets:,}" if self.adaptive_buckets else ""
            return (f"BlockHashParams(preset={self.preset!r}, k={self.k}, A={self.A}, L={self.L}, "
                    f"S={self.bucket_photons:g} photons/bucket{built}, B={self.B}, layout=adaptive"
                    f"{', probe' if self.probe and not self.best_first else ''}"
                    f"{f', nearest-box-first over {self.trees_walked}' if self.best_first else ''}"
                    f"{', lookup=cells' if self.cells else ''})")
        return (f"BlockHashParams(preset={self.preset!r}, k={self.k}, A={self.A}, L={self.L}, "
                f"P=({px}, {py}, {pz}), B={self.B}, layout={self.layout.name.lower()})")


def candidate_cap(params, k: int, A: int, lookup: str = "walk") -> int:
    """The candidates a query examines at most: ``A * k``, and for the walk of an index with
    a ``walk_floor``, ``A * max(k, walk_floor)``."""
    if lookup == "walk" and k < params.walk_floor:
        return int(A) * int(params.walk_floor)
    return int(A) * int(k)


def paper_params(n: int, *, k: int, A: int) -> BlockHashParams:
    """Section 5: L = P = round(ln N), B = ceil(A k / (10 L))."""
    lnN = max(1, round(math.log(n)))
    B = math.ceil(A * k / (PHOTONS_PER_BLOCK * lnN))
    return BlockHashParams(k=k, A=A, L=lnN, P=(lnN, lnN, lnN), B=B,
                           layout=ThresholdLayout.MARGINAL, preset="paper")


def buckets_per_axis(extents, cells: float) -> tuple[int, int, int]:
    """Split ``cells`` buckets over the axes in proportion to their extents.

    Axes thinner than one bucket side get one bucket; the others share the rest
    so that buckets are roughly cubical (square on a plane).
    """
    e = np.asarray(extents, dtype=np.float64)
    live = e > 0
    P = np.ones(3, dtype=np.int64)
    while live.any():
        d = int(live.sum())
        side = (np.prod(e[live]) / max(cells, 1.0)) ** (1.0 / d)
        thin = live & (e < side)
        if not thin.any():
            P[live] = np.maximum(1, np.round(e[live] / side)).astype(np.int64)
            break
        live &= ~thin
    return tuple(int(min(p, MAX_P)) for p in P)


def grid_params(positions: np.ndarray, params: BlockHashParams, layout) -> BlockHashParams:
    """The default preset on a grid layout (``layout=`` given without ``P=``): buckets of the
    same S photons, spread over the axes by their 5th-95th percentile extents."""
    sample = positions[::max(1, len(positions) // 200_000)]
    lo, hi = np.percentile(sample, (5.0, 95.0), axis=0)
    P = buckets_per_axis(hi - lo, len(positions) / params.bucket_photons)
    return replace(params, P=P, layout=layout, probe=False, best_first=False, bucket_photons=0.0)


def adaptive_params(positions: np.ndarray, *, k: int, A: int,
                    photons_per_bucket: float = DEFAULT_PHOTONS_PER_BUCKET,
                    L: int = DEFAULT_L,
                    refs_per_photon: float = DEFAULT_REFS_PER_PHOTON,
                    block_slack: float = DEFAULT_BLOCK_SLACK,
                    walk_trees: int = DEFAULT_WALK_TREES,
                    walk_floor: int = DEFAULT_WALK_FLOOR) -> BlockHashParams:
    """The default preset: the ADAPTIVE layout (:mod:`.adaptive`) with buckets of
    ``S = photons_per_bucket * k * A / ADAPTIVE_REFERENCE_A`` photons (at least a block's)."""
    S = max(PHOTONS_PER_BLOCK, photons_per_bucket * k * A / ADAPTIVE_REFERENCE_A)
    B_need = math.ceil(block_slack * S / PHOTONS_PER_BLOCK)
    B_budget = max(1, int(refs_per_photon * S / L))
    B = max(1, min(B_need, B_budget, MAX_B))
    return BlockHashParams(k=k, A=A, L=L, P=(1, 1, 1), B=B, layout=ThresholdLayout.ADAPTIVE,
                           preset="default", bucket_photons=float(S), probe=True,
                           best_first=True, walk_trees=walk_trees, walk_floor=walk_floor)


def resolve_params(positions: np.ndarray, *, k, A, preset: str = "default",
                   L=None, P=None, B=None, layout=None) -> BlockHashParams:
    """Validate the options and return the preset's parameters with overrides applied."""
    n = len(positions)
    k = as_int(k, "k", minimum=1, maximum=n, hint=f"use k <= N={n:,} or add photons")
    A = as_int(A, "A", minimum=1, hint="A multiplies k to give the candidate budget A*k")
    if preset not in PRESETS:
        raise InputError(f"preset={preset!r} is not known; choose one of {', '.join(PRESETS)}")
    params = (paper_params(n, k=k, A=A) if preset == "paper"
              else adaptive_params(positions, k=k, A=A))
    changes = {}
    if L is not None:
        changes["L"] = as_int(L, "L", minimum=1, maximum=MAX_L)
    if P is not None:
        if np.ndim(P) == 0:
            P = (P, P, P)
        if len(P) != 3:
            raise InputError(f"P={P!r} must be one int or three (Px, Py, Pz)")
        changes["P"] = tuple(as_int(p, f"P[{i}]", minimum=1, maximum=MAX_P) for i, p in enumerate(P))
        if layout is None and params.layout == ThresholdLayout.ADAPTIVE:
            changes["layout"] = ThresholdLayout.MARGINAL  # a grid of P buckets per axis was asked for
    if B is not None:
        changes["B"] = as_int(B, "B", minimum=1, maximum=MAX_B)
    if layout is not None:
        names = [m.name.lower() for m in ThresholdLayout]
        if str(layout).lower() in RETIRED_LAYOUTS:
            raise InputError(f"layout={layout!r} was retired: {RETIRED_LAYOUTS[str(layout).lower()]}")
        if str(layout).lower() not in names:
            raise InputError(f"layout={layout!r} is not known; choose one of {', '.join(names)}")
        changes["layout"] = ThresholdLayout[str(layout).upper()]
        if P is None and params.layout == ThresholdLayout.ADAPTIVE and \
                changes["layout"] != ThresholdLayout.ADAPTIVE:
            params = grid_params(positions, params, changes.pop("layout"))
            changes["P"] = params.P
    if changes:
        # Tables overridden: their own query answers (the cells do not read L, P, B or the
        # layout); lookup='cells' at query time still reads the cells.
        params = replace(params, preset=f"{params.preset}+overrides", cells=False, **changes)
    if params.layout != ThresholdLayout.ADAPTIVE:  # probing follows the adaptive layout's cuts
        params = replace(params, probe=False, best_first=False, bucket_photons=0.0)
    elif params.bucket_photons == 0.0:  # the paper's preset on the adaptive layout
        params = replace(params, bucket_photons=adaptive_params(positions, k=k, A=A).bucket_photons)
    if params.L > MAX_L or params.B > MAX_B:
        raise InputError(f"{params!r} exceeds L <= {MAX_L}, B <= {MAX_B}; pass smaller L or B")
    refs = params.refs
    if params.layout == ThresholdLayout.ADAPTIVE:  # buckets are known after the build: estimate
        refs = params.L * params.B * math.ceil(2 * n / params.bucket_photons)
    if refs > MAX_REFS:
        raise CapacityError(
            f"{params!r} needs {refs:,} block references > {MAX_REFS:,}; "
            "use smaller P, L or B")
    return params
