"""How a render finds each shading point's photons (:class:`LookupOptions`); how it
turns them into radiance is :class:`blockhash.frame.estimate.EstimateOptions`."""

from __future__ import annotations

from dataclasses import dataclass

from blockhash.errors import InputError
from blockhash.validate import as_int

#: The photon searches a render can use: ``auto`` is the cover gather for the conserving
#: estimate and the Block Hashing walk for the k-nearest estimates.
METHODS = ("auto", "cover", "bh", "kdtree", "cpu")
#: The searches that find the k nearest photons (every estimate).
KNN_METHODS = ("bh", "kdtree")


def resolve_method(method: str, estimate: str) -> str:
    """The search ``method`` stands for with ``estimate``: ``auto`` -> ``cover`` (conserving)
    or ``bh``; ``cover`` with a k-nearest estimate is an error naming the way out."""
    if method == "auto":
        return "cover" if estimate == "conserving" else "bh"
    if method == "cover" and estimate != "conserving":
        raise InputError(f"method='cover' sums the conserving estimate only; estimate={estimate!r} "
                         "needs the k nearest photons: use method='bh' (the walk) or 'kdtree'")
    return method


@dataclass(frozen=True)
class LookupOptions:
    """How the caustic pass finds each shading point's photons.

    method : {'auto', 'cover', 'bh', 'kdtree', 'cpu'}
                                       'auto' (the default): 'cover' for the conserving
                                       estimate, else 'bh'.  'cover': every photon whose
                                       own disc covers the point, in the shader
                                       (blockhash.index.lookups.cover); 'bh': the k nearest by
                                       Block Hashing in the shader; 'kdtree': the exact k
                                       nearest, kd-tree shader; 'cpu': the CPU reference of
                                       what 'auto' picks
    k, A : int, optional               neighbours and accuracy multiplier (None: the
                                       scene's ``[photons]`` k and A)
    variant : str                      the shader variant of 'bh'
                                       (``blockhash.gl.shaderlib.variants()``)
    """

    method: str = "auto"
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
