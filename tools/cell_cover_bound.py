"""How many photons a lookup that reads whole cells of one level must read to be exact.

A bounded cell lookup (``lookup='cells'``, :mod:`blockhash.index.lookups.cells_query`) reads
whole octree cells of one level around the query, a fixed number of them, and so
reads every photon of every cell it needs.  This script measures the least it could
read and still return the exact k nearest: for each query, the exact k-th distance
``r_k`` (cKDTree on the index's decoded positions), and at every level the cells that
meet the ball of radius ``r_k`` around the query.  Among the levels where those are at
most ``--cells`` cells, the fewest photons they hold is the bound: no lookup of
``--cells`` cells of one level can be exact with fewer candidates, however its
cells are chosen and however many rounds it takes.  The script prints, per map, the
share of near and far queries (``metrics.far_queries``) whose bound exceeds the cap
``A k``.

    python tools/cell_cover_bound.py                          # every map, N = 10^5, A 8 and 64
    python tools/cell_cover_bound.py --maps clustered --cells 27,125 --json out.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from blockhash.evaluate.accuracy_runs import REPORT, TUNE, photon_map
from blockhash.evaluate.metrics import exact_knn, far_queries
from blockhash.evaluate.photon_maps import queries
from blockhash.index.lookups.cells import CODE_SHIFT, LEVEL_MIN, LEVEL_TOP
from blockhash.index.records.fixedpoint import Quantizer

ROOT = Path(__file__).resolve().parents[1]


def level_counts(codes: np.ndarray, level: int):
    """Sorted packed cell keys of level ``level`` and the photons in each."""
    c = (codes.astype(np.int64) >> (CODE_SHIFT + level))
    keys = (c[:, 0] << 42) | (c[:, 1] << 21) | c[:, 2]
    return np.unique(keys, return_counts=True)


def cover_bound(q_codes: np.ndarray, r_codes: np.ndarray, tables, max_cells: int) -> np.ndarray:
    """(m,) fewest photons in at most ``max_cells`` cells of one level that meet each
    query's ball (centre and radius in 32-bit code units); inf where no level qualifies."""
    best = np.full(len(q_codes), np.inf)
    for level, (keys, counts) in tables.items():
        side = float(1 << (CODE_SHIFT + level))
        lo = np.floor((q_codes - r_codes[:, None]) / side).astype(np.int64)
        hi = np.floor((q_codes + r_codes[:, None]) / side).astype(np.int64)
        span = (hi - lo + 1).prod(axis=1)
        for i in np.flatnonzero(span <= 8 * max_cells):  # the box around the ball first
            axes = [np.arange(lo[i, a], hi[i, a] + 1) for a in range(3)]
            g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
            near = np.clip(q_codes[i], g * side, (g + 1) * side)
            meet = ((near - q_codes[i]) ** 2).sum(axis=1) <= r_codes[i] ** 2
            g = g[meet & (g >= 0).all(axis=1)]
            if len(g) > max_cells:
                continue
            key = (g[:, 0] << 42) | (g[:, 1] << 21) | g[:, 2]
            j = np.searchsorted(keys, key)
            j = np.minimum(j, len(keys) - 1)
            total = np.where(keys[j] == key, counts[j], 0).sum()
            best[i] = min(best[i], total)
    return best


def study(name: str, n: int, m: int, k: int, As, cells) -> list[dict]:
    pm = photon_map(name, ROOT / "scenes")
    pts = pm.photons(n, np.random.default_rng(0))
    q = queries(pm, m, np.random.default_rng(1)).astype(np.float32)
    # The index's fixed point (its cells are octree cells of these codes) and the positions
    # it decodes; no tables are needed.
    quantizer = Quantizer.for_points(pts)
    codes = quantizer.encode(pts)
    d, _ = exact_knn(quantizer.decode(codes), q, k)
    far = far_queries(d)
    step = float(quantizer.step[0])
    q_codes = (q.astype(np.float64) - quantizer.lo.astype(np.float64)) / step
    r_codes = d[:, -1] / step
    tables = {lv: level_counts(codes, lv) for lv in range(LEVEL_MIN, LEVEL_TOP + 1)}
    rows = []
    for c in cells:
        bound = cover_bound(q_codes, r_codes, tables, c)
        for A in As:
            over = bound > A * k
            rows.append({"map": name, "set": "tune" if name in TUNE else "report", "photons": n,
                         "queries": m, "k": k, "A": A, "cells": c,
                         "far_share": float(far.mean()),
                         "over_near": float(over[~far].mean()) if (~far).any() else 0.0,
                         "over_far": float(over[far].mean()) if far.any() else 0.0,
                         "median_bound_far": float(np.median(bound[far])) if far.any() else 0.0})
            r = rows[-1]
            print(f"{name:12s} cells<={c:<4d} A={A:<3d} over the cap: near {100 * r['over_near']:5.1f}%  "
                  f"far {100 * r['over_far']:5.1f}% (far queries {100 * r['far_share']:.0f}%, "
                  f"median far bound {r['median_bound_far']:.0f})", flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maps", default=",".join(TUNE + REPORT))
    ap.add_argument("--photons", type=float, default=1e5)
    ap.add_argument("--queries", type=int, default=4000)
    ap.add_argument("--k", type=int, default=50)
    ap.add_argument("--A", default="8,64")
    ap.add_argument("--cells", default="27,125")
    ap.add_argument("--json")
    a = ap.parse_args()
    rows = []
    for name in a.maps.split(","):
        rows += study(name, int(a.photons), a.queries, a.k, [int(x) for x in a.A.split(",")],
                      [int(x) for x in a.cells.split(",")])
    if a.json:
        cmd = "python tools/cell_cover_bound.py " + " ".join(sys.argv[1:])
        Path(a.json).write_text(json.dumps({"command": cmd.strip(), "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
