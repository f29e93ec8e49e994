"""Block Hashing parameters and their presets (paper section 5).

``BlockHashParams`` holds k, A, L, P (buckets per axis) and B.  Two presets
choose them from the photon set:

``paper``
    Exactly section 5: ``L = P = round(ln N)`` on every axis and
    ``B = ceil(A k / (10 L))``, marginal thresholds.  Kept so that the
    paper's figures can be reproduced.  ``P = ln N`` grows much more slowly than the ``(N / k)^(1/3)``
    that puts about k photons in a bucket, so accuracy falls as N grows, and on
    a planar caustic only ``P^2`` of the ``P^3`` buckets are live.

``default``
    Sizes buckets to the photon distribution, in four steps:

    1. the number of buckets is set so that a bucket holds about
       ``DEFAULT_PHOTONS_PER_BUCKET * k`` photons;
    2. each axis gets buckets in proportion to its robust extent (the 5th-95th
       percentile range); an axis thinner than one bucket gets a single bucket
       (a caustic on a floor hashes in x and z only), and so does an axis on
       which one plane holds more than ``PLANE_SHARE`` of the photons (a floor
       with a lit wall: quantile thresholds cannot split photons that share one
       coordinate, so splitting that axis only overfills the floor's buckets);
    3. the buckets are rebalanced over the live axes so that the nested grid's
       buckets are less elongated (:func:`balance_nested_shape`): nested
       thresholds cut x into slabs from the x marginal alone, so in dense
       regions (a caustic band, a cluster) buckets come out wide in x and thin
       in the axes split later;
    4. ``B`` holds up to ``DEFAULT_BLOCK_SLACK`` times the blocks that a bucket's
       photons fill (blocks straddle bucket borders), capped by the memory bound
       of ``DEFAULT_REFS_PER_PHOTON`` block references per photon.

    Thresholds are nested (:class:`~blockhash.index.thresholds.ThresholdLayout`), so
    every bucket holds about that many photons however clustered the caustic is.

The default preset's constants were chosen with ``tools/tune_params.py``; each
says which measurement fixed it.  Every parameter can be overridden by keyword.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .blocks import PHOTONS_PER_BLOCK
from ..errors import CapacityError, InputError
from .thresholds import ThresholdLayout
from ..validate import as_int

PRESETS = ("default", "paper")
#: Upper limits that keep the tables addressable and the shader's arrays small.
MAX_L = 64
MAX_P = 4096
MAX_B = 256
#: Block references allowed in the whole index: 2**28 refs is 1 GiB of int32.
MAX_REFS = 1 << 28

#: Photons per bucket, as a multiple of k.  tools/tune_params.py --ppb (caustic-like, N = 10^6,
#: k = 50, A = 8, 50,000 queries drawn with the photons, seeds 0 and 3; commands in its
#: docstring): mean average dilation 1.0377/1.0394 at 1.25, 1.0345/1.0372 at 1.5,
#: 1.0354/1.0378 at 1.75, 1.0390/1.0397 at 2 (the old value).  Smaller buckets are each
#: covered by fewer candidates; larger ones spend the A*k budget in fewer tables.
DEFAULT_PHOTONS_PER_BUCKET = 1.5
#: The A at which the default preset's buckets hold DEFAULT_PHOTONS_PER_BUCKET * k photons;
#: they grow in proportion to A, so that the L buckets a query visits hold about its A * k
#: candidates (the paper's B = ceil(A k / 10 L) rule, with the buckets sized instead).
ADAPTIVE_REFERENCE_A = 8
#: Tables.  A query stops after A*k candidates, about 40 blocks, which 2-3 buckets supply, so
#: tables beyond those mostly buy a better choice by priority: --L 6,7,8 gives 1.0365/1.0395,
#: 1.0345/1.0372, 1.0347/1.0373 (same runs as above), and the build's threshold and insertion
#: passes grow linearly with L, so 7 tables build ~10% faster than 8 at the same accuracy.
DEFAULT_L = 7
#: The issue's memory bound is 2.5 block references per photon; keep a margin.
DEFAULT_REFS_PER_PHOTON = 2.4
#: B holds up to this many times the blocks that a bucket's photons fill.  Full buckets drop
#: the blocks that straddle their border, and queries near the border need exactly those.
#: --slack 2,2.5,3,3.5 (same runs): 1.0398/1.0410, 1.0364/1.0392, 1.0345/1.0372, 1.0346/1.0368;
#: 3 takes nearly all of the gain at 2.15 references per photon (3.5 nears the cap above: 2.34).
DEFAULT_BLOCK_SLACK = 3.0
#: Percentiles bounding an axis' robust extent: 5% of photons off the plane do not
#: make an axis live.
EXTENT_PERCENTILES = (5.0, 95.0)
#: Photons sampled (without replacement, seeded) to measure extents, planes and bucket shapes.
EXTENT_SAMPLE = 200_000
#: An axis on which more than this share of the photons share one coordinate gets one bucket.
#: Measured on caustic-like floors with a lit ring wall of growing weight (N = 3 x 10^5, k = 50,
#: tools/tune_params.py --data caustic-wallNN): with 94%, 88% and 75% of the photons on the floor
#: one y bucket beats splitting y (mean average dilation 1.029 vs 1.105, 1.057 vs 1.418, 1.171 vs
#: 1.396); with 48% and 24% splitting y wins (1.184 vs 1.606, 1.071 vs 2.197).
PLANE_SHARE = 0.5
#: "One coordinate" means within this fraction of the largest robust extent: far below any bucket
#: side (MAX_P buckets per axis), far above the rounding of a float64 ray-plane hit (~1e-16).
PLANE_TOLERANCE = 1e-6
#: Strength of the nested-shape rebalancing (:func:`balance_nested_shape`); 1 would equalise the
#: buckets' mean log2 spread over the live axes as measured on the coarse grid below.
#: --shape 0,0.5,0.75,1,1.5,2 (N = 10^6, k = 50, 20,000 queries, seed 0): caustic-like
#: 1.0448/1.0380/1.0358/1.0355/1.0396/1.0481, 'clustered' 1.1038/1.0546/1.0415/1.0323/1.0361/1.0425.
#: With caustic-like queries drawn apart from the photons (--query-mode seed, as
#: tests/test_index.py draws them: other hot spots, so more queries in the dim background, where
#: balancing makes buckets taller), seeds 3 and 4 (50,000 queries): 1.0500/1.0561 at 0.5,
#: 1.0490/1.0579 at 0.75, 1.0505/1.0609 at 1.  0.75 is the compromise.
SHAPE_STRENGTH = 0.75
#: Photons (at most, a seeded sample) on which planes and bucket shapes are measured, and photons
#: per bucket of the coarse grid that measures shapes: 16 give each bucket a usable spread, and
#: 50,000 photons keep both measurements near 30 ms at N = 10^6 (the build takes ~1.1 s).
SHAPE_SAMPLE = 50_000
SHAPE_PHOTONS_PER_BUCKET = 16


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
    layout : ThresholdLayout  marginal (paper) or nested thresholds
    preset : str      where the values came from
    """

    k: int
    A: int
    L: int
    P: tuple[int, int, int]
    B: int
    layout: ThresholdLayout = ThresholdLayout.NESTED
    preset: str = "custom"
    #: ADAPTIVE layout only: target photons per bucket, and the buckets per table that
    #: the build made (0 until then).
    bucket_photons: float = 0.0
    adaptive_buckets: int = 0

    @property
    def axis(self) -> int:
        """ADAPTIVE layout: the level-1 axis, the one with the most buckets in P."""
        return int(np.argmax(self.P))

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
                    f"P1={self.P[self.axis]} on {'xyz'[self.axis]}, "
                    f"S={self.bucket_photons:g} photons/bucket{built}, B={self.B}, layout=adaptive)")
        return (f"BlockHashParams(preset={self.preset!r}, k={self.k}, A={self.A}, L={self.L}, "
                f"P=({px}, {py}, {pz}), B={self.B}, layout={self.layout.name.lower()})")


def paper_params(n: int, *, k: int, A: int) -> BlockHashParams:
    """Section 5: L = P = round(ln N), B = ceil(A k / (10 L))."""
    lnN = max(1, round(math.log(n)))
    B = math.ceil(A * k / (PHOTONS_PER_BLOCK * lnN))
    return BlockHashParams(k=k, A=A, L=lnN, P=(lnN, lnN, lnN), B=B,
                           layout=ThresholdLayout.MARGINAL, preset="paper")


def photon_sample(positions: np.ndarray, *, sample: int = EXTENT_SAMPLE, seed: int = 0) -> np.ndarray:
    """At most ``sample`` photons drawn without replacement (in random order), seeded."""
    if len(positions) > sample:
        return positions[np.random.default_rng(seed).choice(len(positions), sample, replace=False)]
    return positions


def plane_shares(positions: np.ndarray, tolerance: float) -> np.ndarray:
    """(3,) largest share of photons whose coordinate on each axis lies within ``tolerance``
    of one value (1.0 on an axis where all photons share one coordinate)."""
    n = len(positions)
    out = np.zeros(3)
    if n == 0:
        return out
    for a in range(3):
        v = np.sort(positions[:, a])
        inside = np.searchsorted(v, v + tolerance, side="right") - np.arange(n)
        out[a] = inside.max() / n
    return out


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


def nested_cells(sample: np.ndarray, P) -> np.ndarray:
    """(m,) bucket of each photon of ``sample`` in an equal-count nested grid.

    The grid is the one ``ThresholdLayout.NESTED`` builds with ``P`` buckets per
    axis and no table offset: x slabs of equal count, then y per slab, then z
    per (x, y) column, each from the photons it splits.
    """
    m = len(sample)
    g = np.zeros(m, dtype=np.int64)
    for a in range(3):
        p = int(P[a])
        if p == 1:
            continue
        order = np.argsort(sample[:, a], kind="stable")
        if g.any():
            rank = np.empty(m, dtype=np.int64)
            rank[order] = np.arange(m)
            order = np.argsort(g * m + rank)
        gs = g[order]
        count = np.bincount(gs)
        pos = np.arange(m) - (np.cumsum(count) - count)[gs]
        g[order] = gs * p + pos * p // count[gs]
    return g


def nested_log_spread(sample: np.ndarray, P) -> np.ndarray:
    """(3,) mean over the buckets of :func:`nested_cells` of log2 of the photons'
    standard deviation along each axis.

    NaN on axes with one bucket, and on every axis when fewer than 32 buckets,
    or fewer than 90% of those holding two photons or more, have a spread on
    every split axis: buckets flat along a split axis (a floor inside a 3D grid)
    have no shape to measure, and where they are common the grid's shape is set
    by that plane rather than by the photon density.
    """
    live = [a for a in range(3) if P[a] > 1]
    out = np.full(3, np.nan)
    if not live or len(sample) < 2:
        return out
    g = nested_cells(sample, P)
    nb = int(g.max()) + 1
    c = np.bincount(g, minlength=nb).astype(np.float64)
    var = np.zeros((3, nb))
    for a in live:
        mean = np.bincount(g, sample[:, a], nb) / np.maximum(c, 1.0)
        var[a] = np.bincount(g, sample[:, a] ** 2, nb) / np.maximum(c, 1.0) - mean * mean
    filled = c >= 2
    ok = filled & np.all(var[live] > 0, axis=0)
    if ok.sum() >= max(32, 0.9 * filled.sum()):
        for a in live:
            out[a] = np.mean(0.5 * np.log2(var[a, ok]))
    return out


def balance_nested_shape(sample: np.ndarray, P, cells: float, *,
                         strength: float = SHAPE_STRENGTH) -> tuple[int, int, int]:
    """Move buckets between the live axes so that nested buckets are less elongated.

    Nested thresholds cut x by its marginal alone, so a slab is as wide in a
    dense caustic band as in the dim background around it; the later axes, split
    per slab or column, then cut the band finely and the background coarsely.
    Photon-weighted, buckets come out too wide in x: the geometric mean of the
    buckets' x / z spread is ~2.9 on the caustic-like set at P = (95, 1, 106), and
    on 'clustered' at P = (22, 19, 24) the x, y, z spreads are ~3.4, ~0.8 and ~0.4
    times their geometric mean.

    ``sample`` is a random sample of the photons (at most ``SHAPE_SAMPLE`` keep
    this near 20 ms).  The spread is measured on a grid with the proportions of
    ``P`` and about ``SHAPE_PHOTONS_PER_BUCKET`` photons of ``sample`` per bucket
    (:func:`nested_log_spread`); each live axis' bucket count is multiplied by
    ``2 ** (strength * d)``, ``d`` being its excess log2 spread over the mean of
    the live axes, which keeps the total.  Uniform data measure ``|d| < 0.03``.
    """
    live = [a for a in range(3) if P[a] > 1]
    if strength == 0 or len(live) < 2:
        return tuple(int(p) for p in P)
    f = min(1.0, len(sample) / SHAPE_PHOTONS_PER_BUCKET / max(cells, 1.0)) ** (1.0 / len(live))
    spread = nested_log_spread(sample, [max(2, round(P[a] * f)) if a in live else 1 for a in range(3)])
    if np.isnan(spread[live]).any():
        return tuple(int(p) for p in P)
    d = spread - np.mean(spread[live])
    return tuple(int(min(MAX_P, max(2, round(P[a] * 2.0 ** (strength * d[a]))))) if a in live else 1
                 for a in range(3))


def default_params(positions: np.ndarray, *, k: int, A: int,
                   photons_per_bucket: float = DEFAULT_PHOTONS_PER_BUCKET,
                   L: int = DEFAULT_L,
                   refs_per_photon: float = DEFAULT_REFS_PER_PHOTON,
                   block_slack: float = DEFAULT_BLOCK_SLACK,
                   plane_share: float = PLANE_SHARE,
                   shape_strength: float = SHAPE_STRENGTH) -> BlockHashParams:
    """Distribution-adapted parameters (see the module docstring).

    ``A`` does not change the tables: it only sets how many candidates a query
    examines, so one index serves every accuracy setting.  The keywords are the
    preset's constants, exposed for tools/tune_params.py.
    """
    n = len(positions)
    cells = max(1.0, n / (photons_per_bucket * k))
    sample = photon_sample(positions)
    lo, hi = np.percentile(sample, EXTENT_PERCENTILES, axis=0)
    extents = hi - lo
    small = photon_sample(sample, sample=SHAPE_SAMPLE, seed=1)
    planes = plane_shares(small, PLANE_TOLERANCE * float(extents.max()))
    flat = planes > plane_share
    if not flat.all():
        # All three flat is a point, not a plane: leave that to the extents.
        extents = np.where(flat, 0.0, extents)
    P = buckets_per_axis(extents, cells)
    P = balance_nested_shape(small, P, cells, strength=shape_strength)
    buckets = P[0] * P[1] * P[2]
    B_need = math.ceil(block_slack * (n / buckets) / PHOTONS_PER_BLOCK)
    B_budget = max(1, int(refs_per_photon * n / (L * buckets)))
    B = max(1, min(B_need, B_budget, MAX_B))
    return BlockHashParams(k=k, A=A, L=L, P=P, B=B, layout=ThresholdLayout.NESTED, preset="default")


def adaptive_params(positions: np.ndarray, *, k: int, A: int,
                    photons_per_bucket: float = DEFAULT_PHOTONS_PER_BUCKET,
                    L: int = DEFAULT_L,
                    refs_per_photon: float = DEFAULT_REFS_PER_PHOTON,
                    block_slack: float = DEFAULT_BLOCK_SLACK) -> BlockHashParams:
    """The default preset: the ADAPTIVE layout (:mod:`.adaptive`) with buckets of
    ``photons_per_bucket * k`` photons; level 1 cuts the axis that
    :func:`buckets_per_axis` gives the most buckets, into that many slabs."""
    n = len(positions)
    S = max(PHOTONS_PER_BLOCK, photons_per_bucket * k * A / ADAPTIVE_REFERENCE_A)
    sample = photon_sample(positions)
    lo, hi = np.percentile(sample, EXTENT_PERCENTILES, axis=0)
    P = buckets_per_axis(hi - lo, max(1.0, n / S))
    B_need = math.ceil(block_slack * S / PHOTONS_PER_BLOCK)
    B_budget = max(1, int(refs_per_photon * S / L))
    B = max(1, min(B_need, B_budget, MAX_B))
    return BlockHashParams(k=k, A=A, L=L, P=P, B=B, layout=ThresholdLayout.ADAPTIVE,
                           preset="default", bucket_photons=float(S))


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
            changes["layout"] = ThresholdLayout.NESTED  # a grid of P buckets per axis was asked for
    if B is not None:
        changes["B"] = as_int(B, "B", minimum=1, maximum=MAX_B)
    if layout is not None:
        names = [m.name.lower() for m in ThresholdLayout]
        if str(layout).lower() not in names:
            raise InputError(f"layout={layout!r} is not known; choose one of {', '.join(names)}")
        changes["layout"] = ThresholdLayout[str(layout).upper()]
    if changes:
        params = replace(params, preset=f"{params.preset}+overrides", **changes)
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
