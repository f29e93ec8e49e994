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

from blockhash.studies.command import ToolParser, count, listing
from blockhash.studies.lookups import accuracy_runs as ea


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    ea.run_options(p)
    p.add_argument("--cells", type=listing(count), default=[27, 125],
                   help="cells of one level a lookup reads (default 27,125)")
    p.json_output("write the rows here")
    a = p.parse_args(argv)
    rows = []
    for name in a.maps:
        rows += ea.cell_cover_rows(name, a.photons, a.queries, a.k, a.A, a.cells,
                                   scenes=p.root / "scenes")
        for r in rows[-len(a.cells) * len(a.A):]:
            print(f"{name:12s} cells<={r['cells']:<4d} A={r['A']:<3d} over the cap: near "
                  f"{100 * r['over_near']:5.1f}%  far {100 * r['over_far']:5.1f}% (far queries "
                  f"{100 * r['far_share']:.0f}%, median far bound {r['median_bound_far']:.0f})",
                  flush=True)
    if a.json:
        ea.save_rows(a.json, __file__, argv, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
