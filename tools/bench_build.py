"""Index build time beside scipy's cKDTree build of the same photons, interleaved.

For each photon map and N, each of ``--repeat`` rounds builds the Block Hashing index
(default preset, k = 50, the given A) and a cKDTree of the same positions, one right after
the other; medians and the ratio of medians are printed, with the build's stages (encode,
blocks, thresholds, insert, pack) from the index's own timings.  numba compiles on a tiny
input first.

    python tools/bench_build.py
    python tools/bench_build.py --maps caustic,room --photons 1e5,1e6 --A 1,8,64 --repeat 5
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from statistics import median

import numpy as np
from scipy.spatial import cKDTree

ROOT = Path(__file__).resolve().parents[1]

from blockhash import BlockHashIndex
from blockhash.evaluate.photon_maps import MAPS


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--maps", default="caustic,room,uniform")
    ap.add_argument("--photons", default="1e6")
    ap.add_argument("--A", default="8")
    ap.add_argument("--k", type=int, default=50)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    BlockHashIndex(MAPS["uniform"].photons(5000, np.random.default_rng(9)), k=8, A=2)
    print(f"{'map':10s} {'N':>10s} {'A':>3s} {'BH s':>7s} {'kd s':>7s} {'ratio':>6s}  stages (median s)")
    for name in args.maps.split(","):
        for n in (int(float(v)) for v in args.photons.split(",")):
            pts = MAPS[name].photons(n, np.random.default_rng(0))
            for A in (int(a) for a in args.A.split(",")):
                bh, kd, stages = [], [], []
                for _ in range(args.repeat):
                    t0 = time.perf_counter()
                    index = BlockHashIndex(pts, k=args.k, A=A)
                    bh.append(time.perf_counter() - t0)
                    t0 = time.perf_counter()
                    cKDTree(pts)
                    kd.append(time.perf_counter() - t0)
                    stages.append(index.timings)
                parts = ", ".join(f"{s} {median(t[s] for t in stages):.3f}"
                                  for s in ("encode", "blocks", "thresholds", "insert", "pack"))
                print(f"{name:10s} {n:>10,} {A:>3d} {median(bh):7.3f} {median(kd):7.3f} "
                      f"{median(bh) / median(kd):6.2f}  {parts}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
