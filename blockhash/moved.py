"""Modules that moved when the package was laid out in data-flow order: importing an old
name still works for one release, with a DeprecationWarning naming the new module."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

#: Old module name -> new module name.
MOVED = {
    "blockhash.render.scene": "blockhash.scene.model",
    "blockhash.render.scene_toml": "blockhash.scene.loader",
    "blockhash.render.scene_values": "blockhash.scene.values",
    "blockhash.render.meshes": "blockhash.scene.meshes",
    "blockhash.render.materials": "blockhash.scene.materials",
    "blockhash.render.optics": "blockhash.scene.optics",
    "blockhash.render.raycast": "blockhash.scene.raycast",
    "blockhash.render.preview": "blockhash.scene.preview",
    "blockhash.render.emission": "blockhash.photons.emission",
    "blockhash.render.tracing": "blockhash.photons.tracing",
    "blockhash.render.lighttrace": "blockhash.reference.lighttrace",
    "blockhash.render.imagediff": "blockhash.evaluate.imagediff",
    "blockhash.render.plots": "blockhash.evaluate.plots",
    "blockhash.render.tolerance": "blockhash.evaluate.tolerance",
    "blockhash.testing": "blockhash.evaluate.testing",
    "blockhash.tradeoff": "blockhash.studies",
    **{f"blockhash.tradeoff.{m}": f"blockhash.studies.{m}"
       for m in ("sweep", "budget", "claims", "estimates", "measure", "report", "sampling")},
    # index/ laid out in its parts: records, tables, lookups; its evaluation data in evaluate/
    "blockhash.index.fixedpoint": "blockhash.index.records.fixedpoint",
    "blockhash.index.codec": "blockhash.index.records.codec",
    "blockhash.index.hilbert": "blockhash.index.records.hilbert",
    "blockhash.index.radixsort": "blockhash.index.records.radixsort",
    "blockhash.index.btree": "blockhash.index.records.btree",
    "blockhash.index.blocks": "blockhash.index.records.blocks",
    "blockhash.index.thresholds": "blockhash.index.tables.thresholds",
    "blockhash.index.adaptive": "blockhash.index.tables.adaptive",
    "blockhash.index.probe": "blockhash.index.tables.probe",
    "blockhash.index.partition": "blockhash.index.tables.partition",
    "blockhash.index.taskpool": "blockhash.index.tables.taskpool",
    "blockhash.index.hashtables": "blockhash.index.tables.hashtables",
    "blockhash.index.params": "blockhash.index.tables.params",
    "blockhash.index.node_boxes": "blockhash.index.tables.node_boxes",
    "blockhash.index.query": "blockhash.index.lookups.hash",
    "blockhash.index.best_first": "blockhash.index.lookups.walk",
    "blockhash.index.cells": "blockhash.index.lookups.cells",
    "blockhash.index.cell_query": "blockhash.index.lookups.cells_query",
    "blockhash.index.datasets": "blockhash.evaluate.datasets",
    "blockhash.index.photon_maps": "blockhash.evaluate.photon_maps",
    "blockhash.index.metrics": "blockhash.evaluate.metrics",
}


#: The frame's package, before ``blockhash.render`` became the render function.
OLD_FRAME = "blockhash.render"


class _Moved(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds an old name of :data:`MOVED` and gives it the new module.  The frame's old
    package name cannot be imported at all: ``blockhash.render`` is the render function, and
    Python would bind the imported package over it; its names fail with the new one."""

    def find_spec(self, name, path=None, target=None):
        if name == OLD_FRAME or name.startswith(OLD_FRAME + "."):
            # Python imports the parent first, so the message cannot name the child module.
            raise ModuleNotFoundError(
                "blockhash.render is the render function now, not a package: the frame's modules "
                "are in blockhash.frame (import blockhash.frame.pipeline for "
                "blockhash.render.pipeline, and so on), and the scene's older names under "
                "blockhash.render are in blockhash.scene, blockhash.photons, blockhash.reference "
                "and blockhash.evaluate", name=name)
        if name in MOVED:
            return importlib.util.spec_from_loader(name, self)
        return None

    def create_module(self, spec):
        return None  # a placeholder, replaced below

    def exec_module(self, module):
        # The import system returns whatever sys.modules holds under the old name once this
        # returns: the new module itself, whose own spec and attributes stay as they are.
        new = MOVED[module.__name__]
        warnings.warn(f"{module.__name__} is now {new}; import it from there",
                      DeprecationWarning, stacklevel=2)
        sys.modules[module.__name__] = importlib.import_module(new)


def install() -> None:
    """Put the finder on ``sys.meta_path`` once."""
    if not any(isinstance(f, _Moved) for f in sys.meta_path):
        sys.meta_path.insert(0, _Moved())  # before the path finder: a stale folder of an
        # old name (a __pycache__ left by an upgrade) would import as an empty namespace
