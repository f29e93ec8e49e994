"""blockhash: low latency photon mapping with Block Hashing (Ma & McCool 2002)."""

__version__ = "0.1.0"

from blockhash import code_version

code_version.configure(__version__)  # before any compiled function is defined

from blockhash.errors import BlockHashError, CapacityError, InputError, InputTypeError, ShaderCompileError
from blockhash.index.block_hash_index import BlockHashIndex, IndexStats, OrphanWarning
from blockhash.index.params import BlockHashParams

__all__ = ["BlockHashIndex", "BlockHashParams", "IndexStats", "OrphanWarning", "BlockHashError", "CapacityError", "InputError", "InputTypeError", "ShaderCompileError", "__version__"]
