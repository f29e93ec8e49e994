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

import numpy as np

from blockhash.studies.command import ToolParser, count, listing
from blockhash.studies.lookups import accuracy_runs as ea


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.add_argument("--maps", type=listing(ea.map_name), default=["caustic", "room", "uniform"],
                   help="photon maps (default caustic,room,uniform)")
    p.photons([1_000_000], many=True, help="photon counts")
    p.add_argument("--A", type=listing(count), default=[8], help="the accuracy knob A (default 8)")
    p.add_argument("--k", type=count, default=50, help="neighbours k (default 50)")
    p.add_argument("--repeat", type=count, default=5, help="rounds (default 5)")
    p.json_output("write the rows here")
    args = p.parse_args(argv)
    ea.warm_up()
    print(f"{'map':10s} {'N':>10s} {'A':>3s} {'BH s':>7s} {'kd s':>7s} {'ratio':>6s}  stages (median s)")
    rows = []
    for name in args.maps:
        for n in args.photons:
            pts = ea.photon_map(name, p.root / "scenes").photons(n, np.random.default_rng(0))
            for A in args.A:
                r = {"map": name, **ea.build_beside_ckdtree(pts, args.k, A, args.repeat)}
                rows.append(r)
                parts = ", ".join(f"{s} {t:.3f}" for s, t in r["stages"].items())
                print(f"{name:10s} {n:>10,} {A:>3d} {r['build_s']:7.3f} {r['ckdtree_s']:7.3f} "
                      f"{r['ratio']:6.2f}  {parts}", flush=True)
    if args.json:
        ea.save_rows(args.json, __file__, argv, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
