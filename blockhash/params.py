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
    Sizes buckets to the photon distribution.  Each axis gets buckets in
    proportion to its robust extent (the 5th-95th percentile range), an axis
    thinner than one bucket gets a single bucket (a caustic on a floor hashes
    in x and z only), and the number of buckets is set so that a bucket holds
    about ``DEFAULT_PHOTONS_PER_BUCKET * k`` photons.  Thresholds are nested
    (:class:`~blockhash.thresholds.ThresholdLayout`), so every bucket holds about
    that many photons however clustered the caustic is.  ``B`` holds twice the
    blocks a bucket's photons fill (blocks straddle bucket borders), capped by the
    memory bound of ``DEFAULT_REFS_PER_PHOTON`` block references per photon.

Every parameter can be overridden by keyword.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .errors import CapacityError, InputError
from .thresholds import ThresholdLayout
from .validate import as_int

PRESETS = ("default", "paper")
#: Upper limits that keep the tables addressable and the shader's arrays small.
MAX_L = 64
MAX_P = 4096
MAX_B = 256
#: Block references allowed in the whole index: 2**28 refs is 1 GiB of int32.
MAX_REFS = 1 << 28
#: Photons per block (section 3.2: six 32-bit words each in a 64-word block).
PHOTONS_PER_BLOCK = 10

#: Chosen with tools/tune_params.py on caustic-like and uniform data (BENCHMARKS.md):
#: buckets of 2k photons, 8 tables.
DEFAULT_PHOTONS_PER_BUCKET = 2.0
DEFAULT_L = 8
#: The issue's memory bound is 2.5 block references per photon; keep a margin.
DEFAULT_REFS_PER_PHOTON = 2.4
#: B holds this many times the blocks that a bucket's photons fill.
DEFAULT_BLOCK_SLACK = 2.0
#: Percentiles bounding an axis' robust extent: 5% of photons off the plane do not
#: make an axis live.
EXTENT_PERCENTILES = (5.0, 95.0)


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

    @property
    def buckets(self) -> int:
        """Buckets per table."""
        return self.P[0] * self.P[1] * self.P[2]

    @property
    def refs(self) -> int:
        """Block reference slots in the whole index, L * buckets * B."""
        return self.L * self.buckets * self.B

    def __repr__(self) -> str:
        px, py, pz = self.P
        return (f"BlockHashParams(preset={self.preset!r}, k={self.k}, A={self.A}, L={self.L}, "
                f"P=({px}, {py}, {pz}), B={self.B}, layout={self.layout.name.lower()})")


def paper_params(n: int, *, k: int, A: int) -> BlockHashParams:
    """Section 5: L = P = round(ln N), B = ceil(A k / (10 L))."""
    lnN = max(1, round(math.log(n)))
    B = math.ceil(A * k / (PHOTONS_PER_BLOCK * lnN))
    return BlockHashParams(k=k, A=A, L=lnN, P=(lnN, lnN, lnN), B=B,
                           layout=ThresholdLayout.MARGINAL, preset="paper")


def robust_extents(positions: np.ndarray, *, sample: int = 200_000, seed: int = 0) -> np.ndarray:
    """(3,) 5th-95th percentile range per axis, from at most ``sample`` photons."""
    if len(positions) > sample:
        idx = np.random.default_rng(seed).choice(len(positions), sample, replace=False)
        positions = positions[idx]
    lo, hi = np.percentile(positions, EXTENT_PERCENTILES, axis=0)
    return hi - lo


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


def default_params(positions: np.ndarray, *, k: int, A: int,
                   photons_per_bucket: float = DEFAULT_PHOTONS_PER_BUCKET,
                   L: int = DEFAULT_L,
                   refs_per_photon: float = DEFAULT_REFS_PER_PHOTON) -> BlockHashParams:
    """Distribution-adapted parameters (see the module docstring).

    ``A`` does not change the tables: it only sets how many candidates a query
    examines, so one index serves every accuracy setting.
    """
    n = len(positions)
    cells = max(1.0, n / (photons_per_bucket * k))
    P = buckets_per_axis(robust_extents(positions), cells)
    buckets = P[0] * P[1] * P[2]
    B_need = math.ceil(DEFAULT_BLOCK_SLACK * (n / buckets) / PHOTONS_PER_BLOCK)
    B_budget = max(1, int(refs_per_photon * n / (L * buckets)))
    B = max(1, min(B_need, B_budget, MAX_B))
    return BlockHashParams(k=k, A=A, L=L, P=P, B=B, layout=ThresholdLayout.NESTED, preset="default")


def resolve_params(positions: np.ndarray, *, k, A, preset: str = "default",
                   L=None, P=None, B=None, layout=None) -> BlockHashParams:
    """Validate the options and return the preset's parameters with overrides applied."""
    n = len(positions)
    k = as_int(k, "k", minimum=1, maximum=n, hint=f"use k <= N={n:,} or add photons")
    A = as_int(A, "A", minimum=1, hint="A multiplies k to give the candidate budget A*k")
    if preset not in PRESETS:
        raise InputError(f"preset={preset!r} is not known; choose one of {', '.join(PRESETS)}")
    params = (paper_params(n, k=k, A=A) if preset == "paper"
              else default_params(positions, k=k, A=A))
    changes = {}
    if L is not None:
        changes["L"] = as_int(L, "L", minimum=1, maximum=MAX_L)
    if P is not None:
        if np.ndim(P) == 0:
            P = (P, P, P)
        if len(P) != 3:
            raise InputError(f"P={P!r} must be one int or three (Px, Py, Pz)")
        changes["P"] = tuple(as_int(p, f"P[{i}]", minimum=1, maximum=MAX_P) for i, p in enumerate(P))
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
    if params.refs > MAX_REFS:
        raise CapacityError(
            f"{params!r} needs {params.refs:,} block references > {MAX_REFS:,}; "
            "use smaller P, L or B")
    return params
