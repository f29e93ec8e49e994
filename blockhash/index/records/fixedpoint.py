"""32-bit fixed-point photon positions over the photon map's bounding box.

Paper section 3.2 / Figure 4: each coordinate of a photon position is a 32-bit
unsigned fixed-point number.  The box is the photons' bounding box, padded so
that the largest coordinate still maps below 2**32.

Two conversions matter, and both are defined so that the GLSL lookup can
reproduce them bit for bit:

* ``encode`` (build time, CPU only): float64 position -> uint32 code,
  ``floor((p - lo) / step)``.  Exact to one step.
* ``decode`` (CPU reference and shader): uint32 code -> float32 position,
  evaluated as ``lo32 + float32(u) * step32`` in float32, one rounding per
  operation (the shader marks the expression ``precise``).
* ``quantize_query`` (CPU reference and shader): float32 query -> uint32 code
  for hashing, evaluated as ``(q - lo32) * inv_step32`` in float32 and
  truncated, with values outside the box mapped to the first or last code.
  Outside points are *hashed* to the edge cells; their distances are still
  computed from the unmodified query.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from blockhash.errors import InputError
from blockhash.validate import as_points

#: Codes per axis: positions map to [0, 2**32).
CODE_RANGE = 2.0**32
#: Largest float32 strictly below 2**32; the float-to-code conversion saturates here.
FLOAT32_BELOW_2_32 = np.float32(4294967040.0)
#: Relative padding of the box on each side, so that no photon lies on the upper face
#: (which would need code 2**32) and float32 decoding stays inside the box.
BOX_PAD = 1e-6
#: A photon box must span at least this many decode error bounds along its longest axis
#: (:meth:`Quantizer.decode_error`), or the build is refused: below it float32 positions
#: barely tell photons apart.  Measured (N = 2,500 uniform 10^4 m from the origin, k = 8,
#: exhaustive search): spans of 0.4, 1.7, 6.7, 13 and 27 bounds find 2%, 25%, 69%, 86% and
#: 92% of the true neighbours; 105 and 420 bounds 97.7% and 99.5%, the rest being neighbours
#: whose distances agree within the bound.  A box 10^-39 m (subnormal) or 10^-12 m across at
#: the origin spans under 10 bounds, and so does a 1 mm scene 10^4 m from the origin.
MIN_RESOLVED_EXTENT = 16.0


@dataclass(frozen=True)
class Quantizer:
    """Maps positions in ``[lo, lo + step * 2**32)`` to uint32 codes per axis.

    Attributes
    ----------
    lo : (3,) float32
        Lower corner of the box (exactly representable in float32).
    step : (3,) float32
        Size of one code step per axis in metres (float32, > 0).
    """

    lo: np.ndarray
    step: np.ndarray

    @classmethod
    def for_points(cls, positions) -> "Quantizer":
        """The quantizer of the padded bounding box of ``positions`` ((n, 3), n >= 1)."""
        # float32 positions are read as they are (their bounds are exact in float64)
        p = as_points(positions, "positions", dtype=np.float32 if getattr(
            positions, "dtype", None) == np.float32 else np.float64)
        if len(p) == 0:
            raise InputError("positions is empty; a photon map needs at least one photon")
        lo, hi = (b.astype(np.float64) for b in _bounds(p))
        extent = hi - lo
        # A degenerate axis (all photons on one plane) still gets a box of non-zero
        # size, scaled to the largest extent so that the step stays meaningful.
        scale = max(float(extent.max()), float(np.maximum(np.abs(lo), np.abs(hi)).max()), 1.0)
        pad = BOX_PAD * scale
        lo32 = np.float32(lo - pad)
        # float32 rounding of lo may move it up; step it down until it is below lo - pad/2.
        lo32 = np.where(lo32.astype(np.float64) > lo - 0.5 * pad,
                        np.nextafter(lo32, np.float32(-np.inf)), lo32).astype(np.float32)
        # One step on every axis: a cube of codes is a cube in metres, so the octree cells
        # of the cell lookup (blockhash/index/lookups/cells.py) reach as far on every axis.
        size = np.full(3, float(((hi + pad) - lo32.astype(np.float64)).max()))
        step = np.float32(size / CODE_RANGE)
        # Round the step up so that hi + pad maps below 2**32 in exact arithmetic.
        step = np.where(step.astype(np.float64) * CODE_RANGE < size,
                        np.nextafter(step, np.float32(np.inf)), step).astype(np.float32)
        quantizer = cls(lo=lo32, step=step)
        span = float(extent.max())
        bound = float(quantizer.decode_error.max())
        if 0.0 < span < MIN_RESOLVED_EXTENT * bound:
            raise InputError(
                f"positions span only {span:.3g} m (photon box [{lo.tolist()}, {hi.tolist()}]), "
                f"but float32 fixed point there resolves positions to {bound:.3g} m; the box "
                f"must span at least {MIN_RESOLVED_EXTENT:g} times that. Express the scene in "
                "larger units (metres, not kilometres) or move it nearer the origin")
        return quantizer

    @property
    def hi(self) -> np.ndarray:
        """Upper corner of the box, float64 (3,)."""
        return self.lo.astype(np.float64) + self.step.astype(np.float64) * CODE_RANGE

    @property
    def decode_error(self) -> np.ndarray:
        """(3,) float64 bound on ``|decode(encode(p)) - p|`` per axis, in metres.

        ``encode`` truncates to one ``step``; ``decode`` evaluates
        ``lo + float32(u) * step`` in float32: ``float32(u)`` and the product round
        by at most ``2**-24`` of ``size = step * 2**32`` each, and the sum by at
        most ``2**-24`` of the largest coordinate ``M = max(|lo|, |hi|)``.  The bound
        is ``step + 2**-22 * (size + M)``, a factor of about two above that sum:
        about ``2.4e-7`` of the box plus ``2.4e-7`` of the distance from the origin
        (``1.2e-3`` m for a box 10^4 m from the origin, ``4.8e-7`` m for a 1 m box
        at the origin).
        """
        step = self.step.astype(np.float64)
        size = step * CODE_RANGE
        M = np.maximum(np.abs(self.lo.astype(np.float64)), np.abs(self.hi))
        return step + 2.0**-22 * (size + M)

    @property
    def inv_step(self) -> np.ndarray:
        """float32 reciprocal of the step, as the shader uses it for query hashing."""
        return (np.float32(1.0) / self.step).astype(np.float32)

    def encode(self, positions) -> np.ndarray:
        """(n, 3) float positions -> (n, 3) uint32 codes, exact to one step.

        Raises InputError for positions outside the box: nothing is clamped.
        """
        p = as_points(positions, "positions", dtype=np.float64)
        codes, i = _encode(p, self.lo.astype(np.float64), self.step.astype(np.float64))
        if i >= 0:
            raise InputError(
                f"positions[{i}]={p[i].tolist()} lies outside the photon map box "
                f"[{self.lo.tolist()}, {self.hi.tolist()}); build the quantizer from all "
                "photons (Quantizer.for_points) before encoding")
        return codes

    def decode(self, codes) -> np.ndarray:
        """(n, 3) uint32 codes -> (n, 3) float32 positions, ``lo + float32(u) * step``."""
        u = np.asarray(codes, dtype=np.uint32)
        with np.errstate(over="raise"):
            return (self.lo + u.astype(np.float32) * self.step).astype(np.float32)

    def quantize_query(self, points) -> np.ndarray:
        """(m, 3) float32 query points -> (m, 3) uint32 codes for hashing.

        Evaluated in float32 exactly as the shader does; points outside the box
        hash to the edge code (their distances are unaffected).  NaN is rejected
        by the caller before this point.
        """
        q = np.asarray(points, dtype=np.float32)
        with np.errstate(over="ignore"):  # far points overflow to inf and saturate, as in GLSL
            t = (q - self.lo) * self.inv_step
        t = np.minimum(np.maximum(t, np.float32(0.0)), FLOAT32_BELOW_2_32)
        return t.astype(np.uint32)


@numba.njit(cache=True, nogil=True)
def _bounds(p):
    """Smallest and largest coordinate per axis of (n >= 1, 3) positions, in one pass."""
    lo = p[0].copy()
    hi = p[0].copy()
    for r in range(1, p.shape[0]):
        for a in range(3):
            x = p[r, a]
            if x < lo[a]:
                lo[a] = x
            if x > hi[a]:
                hi[a] = x
    return lo, hi


@numba.njit(cache=True, nogil=True)
def _encode(p, lo, step):
    """``floor((p - lo) / step)`` as uint32 codes, and the first row with a code outside
    [0, 2**32) (-1 when none)."""
    n = p.shape[0]
    codes = np.empty((n, 3), dtype=np.uint32)
    first_bad = -1
    for r in range(n):
        for a in range(3):
            u = np.floor((p[r, a] - lo[a]) / step[a])
            if u >= 0.0 and u < CODE_RANGE:
                codes[r, a] = np.uint32(u)
            else:
                codes[r, a] = 0
                if first_bad < 0:
                    first_bad = r
    return codes, first_bad


def min_radius(index) -> float:
    """The smallest radius the density estimate divides by, for an index (anything with a
    ``quantizer``): the photon map's decode error bound (:attr:`Quantizer.decode_error`,
    largest axis).  Photon positions are not known more closely, and the floor keeps ``Phi / (pi r^2)`` finite where the k
    nearest photons coincide with the shading point (r = 0 would give 0 or inf)."""
    return float(index.quantizer.decode_error.max())


def min_r2(index) -> float:
    """``min_radius(index) ** 2`` rounded to float32, as the shader receives it."""
    return float(np.float32(min_radius(index) ** 2))
