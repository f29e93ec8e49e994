"""The exact k nearest photons: scipy's cKDTree, the oracle every lookup is measured against and
the exact baseline of the renderer (``method='kdtree'`` on the CPU)."""

from __future__ import annotations

from scipy.spatial import cKDTree

from blockhash.validate import as_int, as_points


def exact_knn(positions, queries, k: int, *, workers: int = -1):
    """Exact k nearest neighbours, ``(distances, indices)`` each (m, k), nearest first."""
    k = as_int(k, "k", minimum=1)
    tree = cKDTree(as_points(positions, "positions"))
    d, i = tree.query(as_points(queries, "queries"), k=[*range(1, k + 1)], workers=workers)
    return d, i
