"""blockhash: low latency photon mapping with Block Hashing (Ma & McCool 2002)."""

from .errors import BlockHashError, CapacityError, InputError, InputTypeError

__version__ = "0.1.0"

__all__ = ["BlockHashError", "CapacityError", "InputError", "InputTypeError", "__version__"]
