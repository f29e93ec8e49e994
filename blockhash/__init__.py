"""blockhash: low latency photon mapping with Block Hashing (Ma & McCool 2002)."""

from .errors import BlockHashError, CapacityError, InputError, InputTypeError, ShaderCompileError
from .index.block_hash_index import BlockHashIndex, IndexStats, OrphanWarning
from .index.params import BlockHashParams

__version__ = "0.1.0"

__all__ = ["BlockHashIndex", "BlockHashParams", "IndexStats", "OrphanWarning", "BlockHashError", "CapacityError", "InputError", "InputTypeError", "ShaderCompileError", "__version__"]
