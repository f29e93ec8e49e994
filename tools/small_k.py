"""The walk at small k: its candidate floor and the tables it walks, on the TUNE maps.

For k below ``walk_floor`` the default preset's walk examines up to A * walk_floor
candidates (not A * k) and walks all L tables (``BlockHashParams.walk_floor``,
``params.DEFAULT_WALK_FLOOR``).  This sweeps the floor and the tables walked and prints
the false negatives (share of k, CPU reference) per map and k, with eval_accuracy's
photon maps and query sets.  The default was chosen on the TUNE maps only:

    python tools/small_k.py                                   # TUNE maps, floors 0,10,20
    python tools/small_k.py --maps plane,venus --floors 20 --tables 5
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from blockhash import BlockHashIndex
from blockhash.evaluate import accuracy_runs as ea
from blockhash.evaluate.metrics import exact_knn, false_negatives

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", default=",".join(ea.TUNE))
    ap.add_argument("--photons", type=float, default=1e5)
    ap.add_argument("--queries", type=int, default=4000)
    ap.add_argument("--k", default="1,2,4,8,16")
    ap.add_argument("--A", type=int, default=8)
    ap.add_argument("--floors", default="0,10,20")
    ap.add_argument("--tables", default="1,5", help="tables walked below the floor")
    a = ap.parse_args(argv)
    ks = [int(x) for x in a.k.split(",")]
    print(f"false negatives (% of k) at A = {a.A}, N = {int(a.photons):,}, "
          f"{a.queries:,} queries")
    print(f"{'map':<12} {'floor':>5} {'tables':>6} " + " ".join(f"{'k=' + str(k):>7}" for k in ks))
    for name in a.maps.split(","):
        pm = ea.photon_map(name, SCENES)
        pts = pm.photons(int(a.photons), np.random.default_rng(0))
        q = ea.queries(pm, a.queries, np.random.default_rng(1)).astype(np.float32)
        indexes = {k: BlockHashIndex(pts, k=k, A=a.A) for k in ks}
        exact = {k: exact_knn(indexes[k].positions, q, k) for k in ks}
        for floor in (int(x) for x in a.floors.split(",")):
            for tables in (int(x) for x in a.tables.split(",")):
                cells = []
                for k in ks:
                    ix = indexes[k]
                    ix.params = replace(ix.params, walk_floor=floor)
                    trees = tables if k < floor else None
                    _, idx = ix.reference_query(q, k=k, walk_trees=trees)
                    fn = false_negatives(np.asarray(idx).reshape(len(q), -1), exact[k][1],
                                         len(pts)).mean() / k
                    cells.append(f"{100 * fn:>6.2f}%")
                print(f"{name:<12} {floor:>5} {tables:>6} " + " ".join(cells), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
