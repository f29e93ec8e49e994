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

from blockhash.studies.command import ToolParser, count, listing
from blockhash.studies.lookups import accuracy_runs as ea


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    ea.run_options(p, maps=ea.TUNE, k=(1, 2, 4, 8, 16), A=8)
    p.add_argument("--floors", type=listing(int), default=[0, 10, 20],
                   help="walk floors (default 0,10,20)")
    p.add_argument("--tables", type=listing(count), default=[1, 5],
                   help="tables walked below the floor (default 1,5)")
    a = p.parse_args(argv)
    print(f"false negatives (% of k) at A = {a.A}, N = {a.photons:,}, {a.queries:,} queries")
    print(f"{'map':<12} {'floor':>5} {'tables':>6} "
          + " ".join(f"{'k=' + str(k):>7}" for k in a.k))
    for name in a.maps:
        for row in ea.walk_floor_rows(name, a.photons, a.queries, a.k, a.A, a.floors, a.tables,
                                      scenes=p.root / "scenes"):
            print(f"{name:<12} {row['floor']:>5} {row['tables']:>6} "
                  + " ".join(f"{100 * row['fn'][k]:>6.2f}%" for k in a.k), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
