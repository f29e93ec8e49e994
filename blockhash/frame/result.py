"""What a render returns: :class:`RenderResult`, the layers as pixel means and what made them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blockhash.index.block_hash_index import BlockHashIndex


@dataclass
class RenderResult:
    """The layers of a render, (h, w, 3) float32 pixel means of ``spp`` samples each
    (``passes`` passes of ``spp / passes``)."""

    direct: np.ndarray
    caustic: np.ndarray
    timings: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    index: BlockHashIndex | None = None
    spp: int = 1
    passes: int = 1
    #: The conserving estimate's radii of the last pass (a :class:`.progressive.PassRadii`,
    #: ``radii(index, k)``), to estimate again on ``index`` as the render did; None for the
    #: k-nearest estimates.
    radii: object = None
    #: The indirect layer (light after a diffuse bounce, :mod:`blockhash.photons.indirect`);
    #: None where the render has none (left out, or a scene whose diffuse surfaces cannot
    #: light one another): then absent from :meth:`layers`, not zero.
    indirect: np.ndarray | None = None

    @property
    def samples(self) -> np.ndarray:
        """(h, w) int32 samples averaged into each pixel."""
        return np.full(self.direct.shape[:2], self.spp, dtype=np.int32)

    @property
    def combined(self) -> np.ndarray:
        total = self.direct + self.caustic
        return total if self.indirect is None else total + self.indirect

    def layers(self) -> dict:
        """The layers by name: direct, caustic, indirect (where the render has it),
        combined (their sum)."""
        out = {"direct": self.direct, "caustic": self.caustic}
        if self.indirect is not None:
            out["indirect"] = self.indirect
        return {**out, "combined": self.combined}
