"""blockhash: low latency photon mapping with Block Hashing (Ma & McCool 2002)."""

__version__ = "0.1.0"

from blockhash import code_version

code_version.configure(__version__)  # before any compiled function is defined

from blockhash.errors import BlockHashError, CapacityError, InputError, InputTypeError, ShaderCompileError
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.options import LookupOptions
from blockhash.index.block_hash_index import BlockHashIndex, IndexStats, OrphanWarning
from blockhash.index.tables.params import BlockHashParams
from blockhash.passes.dask_cluster import DaskCluster
from blockhash.passes.executors import InProcess, LocalWorkers
from blockhash.passes.pipeline import render
from blockhash.passes.plan import RenderPlan
from blockhash.passes.renderer import Renderer
from blockhash.passes.schedule import Schedule
from blockhash.passes.session import FrameSession


def load_scene(path):
    """The scene of a TOML file (the format: :mod:`blockhash.scene.loader`)."""
    from blockhash.scene.loader import load_scene as load

    return load(path)


__all__ = ["load_scene", "render", "Renderer", "FrameSession", "RenderPlan", "Schedule", "InProcess", "LocalWorkers", "DaskCluster", "EstimateOptions", "LookupOptions", "BlockHashIndex", "BlockHashParams", "IndexStats", "OrphanWarning", "BlockHashError", "CapacityError", "InputError", "InputTypeError", "ShaderCompileError", "__version__"]
