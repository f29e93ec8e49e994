"""How a render's passes shrink their radii: Knaus and Zwicker's schedule (:class:`Schedule`,
:func:`shrink`) and the radii a pass gives its photons (:class:`PassRadii`, :class:`FixedRadii`).

The squared radius of pass i (1-based) is ``r_1^2 prod_{j=2..i} (j - 1 + alpha) / j``, so the
variance of a pass grows as ``i^(1 - alpha)`` while the bias falls as ``r_i^2``, and the mean of
the passes converges to the unbiased image (MSE about ``N^-(2/3)`` passes at ``alpha = 2/3``).
It is a function of the pass number alone: passes are independent, whichever process runs them.
``r_1`` is each photon's own radius (its j-th nearest other photon in its own pass,
:mod:`blockhash.frame.photon_radius`).

The footprint (explained here once; elsewhere referred to): a photon whose disc is under
``footprint`` pixel footprints across (``2 r < footprint * d * pixel angle`` at distance d;
the bound shrinking with the radii, as ``sqrt(shrink)``) and that the camera sees directly is
splatted into its pixel (:mod:`blockhash.frame.pixel_splat`, which derives the splat), so a
focus smaller than a pixel gives the pixel's mean, not a point sample of it.  Only the cover
gather and its CPU reference splat; the other searches gather every photon.  0 splats none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from blockhash.errors import InputError
from blockhash.index.records.fixedpoint import min_r2

#: Knaus and Zwicker's alpha: the share of a pass's photons kept in the next radius.
DEFAULT_ALPHA = 2.0 / 3.0
#: The footprint (module docstring) at pass 1.
DEFAULT_FOOTPRINT = 1.0


def shrink(pass_index: int, alpha: float) -> float:
    """The factor on the squared radii of pass ``pass_index`` (0-based):
    ``prod_{j=2..p+1} (j - 1 + alpha) / j`` (1 for the first pass)."""
    return math.exp(sum(math.log((j - 1 + alpha) / j) for j in range(2, pass_index + 2)))


@dataclass(frozen=True)
class PassRadii:
    """The squared radii of one pass of the conserving estimate: ``base(index, k)`` (each
    photon's own, :mod:`.photon_radius`) times ``scale``, at least the map's position error;
    float32 steps as the shader reads them.  Hashable and holding no index, so the caches
    keyed by the index let it go with the pass."""

    base: object
    scale: float = 1.0

    def __call__(self, index, k: int) -> np.ndarray:
        r2 = self.base(index, k)
        if self.scale == 1.0:
            return r2
        return np.maximum(r2 * self.scale, min_r2(index)).astype(np.float32).astype(np.float64)


@dataclass(eq=False)
class FixedRadii:
    """Squared radii computed before (on the pass's whole map, for the photons the gather
    keeps after the pixel splat took the rest): ``r2`` whatever the index.  Hashed by
    identity: one per pass."""

    r2: np.ndarray

    def __call__(self, index, k: int) -> np.ndarray:
        if len(index) != len(self.r2):
            raise InputError(f"these radii belong to a map of {len(self.r2):,} photons, not "
                             f"{len(index):,}; estimate on the render's own index")
        return self.r2


@dataclass(frozen=True)
class Schedule:
    """How a progressive render's passes shrink their radii.

    alpha : float in (0, 1)      Knaus and Zwicker's alpha (module docstring)
    footprint : float >= 0       the footprint at pass 1 (module docstring); 0: no splat
    """

    alpha: float = DEFAULT_ALPHA
    footprint: float = DEFAULT_FOOTPRINT

    def __post_init__(self):
        if not (isinstance(self.alpha, (int, float)) and 0.0 < self.alpha < 1.0):
            raise InputError.about("{alpha}{value!r} is outside (0, 1): the share of a pass's "
                                   "photons kept in the next radius; use e.g. {alpha}{default:.3g}",
                                   value=self.alpha, default=DEFAULT_ALPHA)
        if not (isinstance(self.footprint, (int, float)) and 0.0 <= self.footprint < math.inf):
            raise InputError.about("{footprint}{value!r}: the disc size in pixel footprints "
                                   "under which photons are splatted into their pixel must be a "
                                   "finite number >= 0 (0 turns the splat off); use e.g. "
                                   "{footprint}{default}", value=self.footprint,
                                   default=DEFAULT_FOOTPRINT)
