"""How a render finds each shading point's photons (:class:`LookupOptions`); how it
turns them into radiance is :class:`blockhash.render.estimate.EstimateOptions`."""

from __future__ import annotations

from dataclasses import dataclass

from blockhash.errors import InputError
from blockhash.validate import as_int

#: The photon searches a render can use.
METHODS = ("bh", "kdtree", "cpu")


@dataclass(frozen=True)
class LookupOptions:
    """How the caustic pass finds each shading point's photons.

    method : {'bh', 'kdtree', 'cpu'}   Block Hashing in the shader, the exact kd-tree
                                       shader, or Block Hashing's CPU reference
    k, A : int, optional               neighbours and accuracy multiplier (None: the
                                       scene's ``[photons]`` k and A)
    variant : str                      the shader variant of 'bh'
                                       (``blockhash.gl.shaderlib.variants()``)
    """

    method: str = "bh"
    k: int | None = None
    A: int | None = None
    variant: str = "default"

    def __post_init__(self):
        if self.method not in METHODS:
            raise InputError(f"method={self.method!r} is not known; choose one of "
                             f"{', '.join(METHODS)}")
        for name in ("k", "A"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, as_int(getattr(self, name), name, minimum=1))
