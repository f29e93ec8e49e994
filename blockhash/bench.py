"""Shader benchmark: Block Hashing variants against exact kNN, in one run (paper section 6).

For one photon map and one query set it times, side by side: each BH shader
variant at each A, the fetch-only shader (same candidate texels, no selection:
the memory floor), the exact kd-tree shader when available, and scipy's cKDTree
on the CPU with all workers.  GL times are the draws alone (after a warm-up
that compiles every program); each figure is the median of ``repeat`` runs.
Recall is measured against the exact neighbours.
"""

from __future__ import annotations

import json
import statistics
import time

import numpy as np

from .index.datasets import DISTRIBUTIONS
from .index.block_hash_index import BlockHashIndex
from .index.metrics import exact_knn, false_negatives


QUERY_SETS = ("image", "random")


def make_queries(pts: np.ndarray, m: int, kind: str, seed: int, data: str) -> np.ndarray:
    """(m, 3) float32 query points.

    ``image``: a raster of pixels over the receiver seen from above, row by row,
    as a caustic pass visits them: the plane y = median(y) across the 1-99%
    x and z range of the photons (neighbouring queries are neighbouring points).
    ``random``: fresh samples of the photon distribution, in random order
    (no coherence between neighbouring queries).
    """
    if kind == "random":
        return DISTRIBUTIONS[data](m, np.random.default_rng(seed)).astype(np.float32)
    side = int(np.ceil(np.sqrt(m)))
    lo, hi = np.percentile(pts[:, [0, 2]], [1, 99], axis=0)
    xs = np.linspace(lo[0], hi[0], side)
    zs = np.linspace(lo[1], hi[1], side)
    gz, gx = np.meshgrid(zs, xs, indexing="ij")
    q = np.stack([gx.ravel(), np.full(gx.size, np.median(pts[:, 1])), gz.ravel()], axis=1)
    return q[:m].astype(np.float32)


def _median_time(fn, repeat):
    times = []
    for _ in range(repeat):
        times.append(fn())
    return statistics.median(times)


def run_benchmark(*, photons=1_000_000, queries=512 * 512, k=50, A_values=(1, 2, 4, 8, 16),
                  variants=("default",), data="caustic", repeat=3, backend=None, seed=0,
                  kdtree=True, query_set="image", progress=print):
    """Run the benchmark and return a list of result rows (dicts)."""
    from scipy.spatial import cKDTree

    from .gl.lookup import GLLookup

    pts = DISTRIBUTIONS[data](photons, np.random.default_rng(seed))
    q = make_queries(pts, queries, query_set, seed + 1, data)
    index = BlockHashIndex(pts, k=k, A=max(A_values))
    positions = index.positions.astype(np.float64)
    progress(f"photons {photons:,} ({data}), queries {queries:,} ({query_set}), k={k}; "
             f"{index.params!r}")
    exact = exact_knn(positions, q, k)
    tree = cKDTree(positions)

    def ckd():
        t = time.perf_counter()
        tree.query(q.astype(np.float64), k=k, workers=-1)
        return time.perf_counter() - t

    rows = [{"method": "cKDTree (CPU, all workers)", "A": None, "seconds": _median_time(ckd, repeat),
             "fn_percent": 0.0}]
    progress(f"cKDTree: {rows[0]['seconds']:.3f} s")
    lookup = GLLookup(index, backend=backend)
    for A in A_values:
        for name, kwargs in [(f"BH {v}", {"variant": v}) for v in variants] + \
                            [("BH fetch-only floor", {"fetch_only": True})]:
            lookup.query(q[:64], k=k, A=A, **kwargs)  # compile outside the timing

            def gl():
                lookup.query(q, k=k, A=A, **kwargs)
                return lookup.counters["gl.draw_seconds"]

            seconds = _median_time(gl, repeat)
            row = {"method": name, "A": A, "seconds": seconds,
                   "candidates": lookup.counters["query.candidates.mean"]}
            if not kwargs.get("fetch_only"):
                _, idx = lookup.query(q, k=k, A=A, **kwargs)
                row["fn_percent"] = 100.0 * false_negatives(idx, exact[1], len(index)).mean() / k
            rows.append(row)
            progress(f"{name} A={A}: {seconds:.3f} s")
    if kdtree:
        try:
            from .gl.kdtree import GLKdTree
        except ImportError:
            progress("kd-tree shader not available")
        else:
            kd = GLKdTree(index.positions, backend=backend)
            kd.query(q[:64], k)

            def kdq():
                kd.query(q, k)
                return kd.counters["gl.draw_seconds"]

            rows.append({"method": "kd-tree shader (exact)", "A": None,
                         "seconds": _median_time(kdq, repeat), "fn_percent": 0.0})
            progress(f"kd-tree shader: {rows[-1]['seconds']:.3f} s")
    return rows


def format_table(rows, queries) -> str:
    by = {(r["method"], r["A"]): r for r in rows}
    ckd = by[("cKDTree (CPU, all workers)", None)]["seconds"]
    kd = by.get(("kd-tree shader (exact)", None), {}).get("seconds")
    lines = [f"{'method':<34} {'A':>3} {'ms/batch':>10} {'queries/s':>12} {'/cKDTree':>9} "
             f"{'/kd-tree':>9} {'/floor':>7} {'FN %k':>6}"]
    for r in rows:
        floor = by.get(("BH fetch-only floor", r["A"]), {}).get("seconds")
        cells = [f"{r['method']:<34}", f"{'' if r['A'] is None else r['A']:>3}",
                 f"{1e3 * r['seconds']:>10.1f}", f"{queries / r['seconds']:>12,.0f}",
                 f"{r['seconds'] / ckd:>9.2f}",
                 f"{r['seconds'] / kd:>9.2f}" if kd else f"{'-':>9}",
                 f"{r['seconds'] / floor:>7.2f}" if floor and r["A"] else f"{'-':>7}",
                 f"{r['fn_percent']:>6.1f}" if "fn_percent" in r else f"{'-':>6}"]
        lines.append(" ".join(cells))
    return "\n".join(lines)


def write_results(rows, path: str) -> None:
    """JSON for plots: a list of rows, one per method and A."""
    with open(path, "w") as fh:
        json.dump(rows, fh, indent=1)
