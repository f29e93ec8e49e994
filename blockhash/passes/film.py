"""The film of a progressive render: running per-pixel means of its passes and the spread
between them.

Each pass brings pixel means of its own samples: a direct layer and a caustic layer whose
photons' powers were divided by the photons that pass emitted.  The film keeps

* the direct layer's mean over passes (each pass one equal share of the samples);
* the caustic layer's mean weighted by each pass's emitted photons: the sum of every pass's
  unnormalised flux over all photons emitted, as SPPM divides by the photons of every pass
  (a pass that stores no photon adds its emitted count and nothing else, so the image stays
  unbiased);
* the indirect layer's mean (light after a diffuse bounce, where the render has it)
  weighted by each pass's indirect photons shot;
* the weighted sum of squared deviations of the caustic layer from its running mean, updated
  by West's incremental algorithm (1979; Welford's, weighted), stable in float64 whatever the
  count of passes or the scale of the values.

From the last, :attr:`Film.caustic_variance` is the per-pixel variance of the caustic mean and
:meth:`Film.estimated_error` the layer's relative standard error: the estimate the stopping
rule ``target_error`` reads.  Only the film grows with a render's length: memory is one
pass's plus these (h, w, 3) float64 arrays.
"""

from __future__ import annotations

import numpy as np

from blockhash.errors import InputError
from blockhash.validate import finite_image

#: What a user can do about a pass that rendered NaN or infinity.
NON_FINITE_WAY_OUT = ("nothing was merged or written from it.  This is a renderer or GL driver "
                      "fault: render the scene with the lookup method 'cpu' (the CPU reference of "
                      "the same estimate) to tell which, and python tools/gpu_conformance.py on this "
                      "device; report it with the scene and the device (blockhash info)")


class Film:
    """Running means of ``(h, w, 3)`` pass images (module docstring)."""

    def __init__(self, height: int, width: int):
        shape = (int(height), int(width), 3)
        self.passes = 0
        self.direct = np.zeros(shape)
        self.caustic = np.zeros(shape)
        self.weight = 0.0      # sum of the passes' weights (photons emitted)
        self.weight2 = 0.0     # sum of their squares: the effective count of passes
        self._m2 = np.zeros(shape)
        #: The indirect layer's mean weighted by each pass's indirect photons shot (None: the
        #: render has none), and that weight's sum.
        self.indirect = None
        self.indirect_weight = 0.0

    def add(self, direct: np.ndarray, caustic: np.ndarray, emitted: int,
            indirect: np.ndarray | None = None, indirect_emitted: int = 0, *,
            source: str = "a pass") -> None:
        """One pass's pixel means; ``emitted`` its photons shot (0 when the scene has no
        specular object, and then every pass weighs the same); ``indirect`` its indirect
        layer (None: the render has none) of ``indirect_emitted`` photons shot.  A layer with
        NaN or infinity is refused (:class:`~blockhash.errors.NonFiniteError` naming
        ``source``, the pass and where it ran), the film left as it was."""
        direct = np.asarray(direct, dtype=np.float64)
        caustic = np.asarray(caustic, dtype=np.float64)
        if direct.shape != self.direct.shape or caustic.shape != self.caustic.shape:
            raise InputError(f"a pass of shape {direct.shape} / {caustic.shape} does not fit the "
                             f"film's {self.direct.shape}; every pass renders the same image size")
        for layer, values in (("direct", direct), ("caustic", caustic), ("indirect", indirect)):
            if values is not None:
                finite_image(values, layer, source, NON_FINITE_WAY_OUT)
        if emitted < 0:
            raise InputError(f"emitted={emitted}: a pass emits a non-negative count of photons")
        w = float(emitted) if emitted > 0 else 1.0
        # New values first, then one assignment: an interrupt (Ctrl-C) leaves the film as it
        # was before the pass or as it is after it, never half-updated.
        passes, weight = self.passes + 1, self.weight + w
        new_direct = self.direct + (direct - self.direct) / passes
        delta = caustic - self.caustic
        new_caustic = self.caustic + delta * (w / weight)
        new_m2 = self._m2 + w * delta * (caustic - new_caustic)
        new_indirect, indirect_weight = self.indirect, self.indirect_weight
        if indirect is not None:
            indirect = np.asarray(indirect, dtype=np.float64)
            wi = float(max(indirect_emitted, 1))
            indirect_weight += wi
            base = np.zeros(self.direct.shape) if self.indirect is None else self.indirect
            new_indirect = base + (indirect - base) * (wi / indirect_weight)
        (self.direct, self.caustic, self._m2, self.weight, self.weight2, self.passes,
         self.indirect, self.indirect_weight) = (new_direct, new_caustic, new_m2, weight,
                                                 self.weight2 + w * w, passes, new_indirect,
                                                 indirect_weight)

    @property
    def effective_passes(self) -> float:
        """Kish's effective count of passes, (sum w)^2 / sum w^2: the passes when they weigh
        the same."""
        return self.weight ** 2 / self.weight2 if self.weight2 else 0.0

    @property
    def caustic_variance(self) -> np.ndarray:
        """(h, w, 3) estimated variance of the caustic mean per pixel: the spread of the
        passes about it over the effective count of passes (inf before two passes)."""
        n = self.effective_passes
        if self.passes < 2 or n <= 1:
            return np.full(self.caustic.shape, np.inf)
        spread = self._m2 / self.weight * n / (n - 1)  # unbiased for equal weights
        return spread / n

    def estimated_error(self) -> float:
        """The caustic layer's relative standard error: sqrt(mean variance of the mean) /
        sqrt(mean squared mean) over all pixels and channels, the noise part of the relative
        RMS error against the converged image (``blockhash.studies.measure.rel_rms``).
        inf before two passes or while the layer is black.  The bias that the passes'
        radii still leave is not in it."""
        var = self.caustic_variance
        scale = float(np.mean(self.caustic ** 2))
        if not np.isfinite(var).all() or scale <= 0:
            return float("inf")
        return float(np.sqrt(np.mean(var) / scale))
