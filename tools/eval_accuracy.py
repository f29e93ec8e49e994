"""The accuracy knob on every evaluation photon map: one table, {default, paper} x A.

For each photon map this script draws N photons (seed 0) and a query set placed
where a renderer places shading points (seed 1): half from the photons'
distribution, half uniform over the map's diffuse surfaces, lit or not
(``blockhash.evaluate.photon_maps.queries``).  For each preset and A it builds an
index (the default preset's buckets follow A, the paper's B does), queries it on
the CPU reference, and compares with exact kNN (cKDTree on the index's decoded
positions, from the float32 queries the index sees): false negatives (mean and 90th percentile, as a share of k), maximum
and average distance dilation, candidates examined, query and build time (the
build beside cKDTree's build of the same photons, same run), block references
and bytes per photon, orphans.  False negatives are also split between queries *near*
the photons and *far* from them (``far_queries``: the exact k-th neighbour within 1.2
times the nearest one's distance, a query farther from every photon than its
neighbourhood is wide).

The maps are split: the default preset's constants were chosen on the TUNE maps
only; the REPORT maps were never used to choose anything.

    python tools/eval_accuracy.py                      # every map, N = 10^6 (about 20 min here)
    python tools/eval_accuracy.py --quick              # N = 10^5, A in {1, 8, 64}
    python tools/eval_accuracy.py --maps tilted,room --A 8 --json out.json
    python tools/eval_accuracy.py --tune --photons 3e5 --A 8 --ppb 0.5,0.75,1,1.5 --L 5,7,9

``--ppb``, ``--L``, ``--slack`` and ``--walk-trees`` sweep the default preset's constants
(photons per bucket as a multiple of k at A = 8, tables, block slack, tables the walk is
seeded with) over their product; ``--layouts adaptive,marginal`` builds the default
preset on each threshold layout (a grid layout takes the preset's P for the photons, the
same buckets per table); ``--tune`` restricts the maps to the TUNE set.
"""

from __future__ import annotations

import itertools
import os
import platform
from pathlib import Path

import numpy as np

from blockhash.studies.command import ToolParser, count, listing, number
from blockhash.studies.lookups import accuracy_runs as ea


def markdown(rows: list[dict]) -> str:
    """Two tables: mean false negatives per map and A for each preset, and the targets at
    the default preset's A = 8."""
    maps = list(dict.fromkeys(r["map"] for r in rows))
    As = sorted({r["A"] for r in rows})
    out = ["| map | set | preset | " + " | ".join(f"A = {A}" for A in As) + " |",
           "|---|---|---|" + "---|" * len(As)]
    for preset in dict.fromkeys(r["preset"] for r in rows):
        for name in maps:
            cells = {r["A"]: r for r in rows if r["map"] == name and r["preset"] == preset}
            if cells:
                first = next(iter(cells.values()))
                out.append(f"| {name} | {first['set']} | {preset} | " + " | ".join(
                    f"{100 * cells[A]['fn_mean']:.2f}%" if A in cells else "" for A in As) + " |")
    out += ["", "| map | set | A | FN mean | FN p90 | FN on / off surface | FN near / far (far share) "
            "| avg dil. | max dil. | candidates | blocks | rounds mean / max | refs/photon "
            "| bytes/photon | orphans | query s | build s (x cKDTree) |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["preset"] == "default" and r["A"] in (8, 64):
            out.append(
                f"| {r['map']} | {r['set']} | {r['A']} | {100 * r['fn_mean']:.2f}% | "
                f"{100 * r['fn_p90']:.0f}% | {100 * r['fn_on']:.2f}% / {100 * r['fn_off']:.2f}% | "
                f"{100 * r.get('fn_near', np.nan):.2f}% / {100 * r.get('fn_far', np.nan):.2f}% "
                f"({100 * r.get('far_share', np.nan):.0f}%) | "
                f"{r['avg_dilation']:.3f} | {r['max_dilation']:.3f} | {r['candidates']:.0f} | "
                f"{r.get('blocks', np.nan):.1f} | {r.get('rounds', np.nan):.1f} / "
                f"{r.get('rounds_max', np.nan):.0f} | {r['refs_per_photon']:.2f} | {r['bytes_per_photon']:.0f} | {r['orphans']} | "
                f"{r['query_seconds']:.2f} | "
                f"{r['build_seconds']:.2f} ({r['build_seconds'] / r['ckdtree_build_seconds']:.1f}x) |")
    out += ["", "Every row (query s: the whole query set, CPU reference):", "",
            "| map | set | preset | A | FN mean | FN p90 | avg dil. | max dil. | candidates "
            "| query s | build s | bytes/photon |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['map']} | {r['set']} | {r['preset']} | {r['A']} | "
                   f"{100 * r['fn_mean']:.2f}% | {100 * r['fn_p90']:.0f}% | "
                   f"{r['avg_dilation']:.3f} | {r['max_dilation']:.3f} | {r['candidates']:.0f} | "
                   f"{r['query_seconds']:.2f} | {r['build_seconds']:.2f} | "
                   f"{r['bytes_per_photon']:.0f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    ea.run_options(p, photons=1_000_000, queries=20_000, A=(1, 2, 4, 8, 16, 32, 64))
    p.add_argument("--presets", type=ea.one_of(*ea.PRESETS), default=list(ea.PRESETS),
                   help=f"presets (default {','.join(ea.PRESETS)})")
    p.add_argument("--quick", action="store_true", help="N = 10^5, 4,000 queries, A in 1, 8, 64")
    p.add_argument("--ppb", type=listing(number),
                   help="sweep: photons per bucket / k at A = 8 (comma-separated)")
    p.add_argument("--L", type=listing(count), help="sweep: tables")
    p.add_argument("--slack", type=listing(number), help="sweep: block slack")
    p.add_argument("--walk-trees", type=listing(count),
                   help="sweep: tables the nearest-box-first walk is seeded with")
    p.add_argument("--layouts", type=listing(str), help="sweep: threshold layouts of the "
                   "default preset (adaptive, marginal)")
    p.add_argument("--tune", action="store_true", help="only the TUNE maps")
    p.add_argument("--lookup", choices=("cells", "walk", "hash"),
                   help="the query (default: the preset's); rounds of dependent fetches per "
                        "query are printed where the query counts them")
    p.add_argument("--markdown", type=Path, help="write the table here")
    ea.rows_options(p, "the rows (and the machine)")
    args = p.parse_args(argv)
    if args.from_json:
        print(markdown(ea.saved_rows(args.from_json)))
        return 0
    if args.quick:
        args.photons, args.queries, args.A = 100_000, 4000, [1, 8, 64]
    sweeps = [[(key, v) for v in values]
              for key, values in (("photons_per_bucket", args.ppb), ("L", args.L),
                                  ("block_slack", args.slack), ("walk_trees", args.walk_trees),
                                  ("layout", args.layouts)) if values]
    configs = [dict(c) for c in itertools.product(*sweeps)] or [{}]
    maps = ea.TUNE if args.tune else args.maps
    rows = []
    ea.warm_up()
    for name in maps:
        rows += ea.evaluate(name, args.photons, args.queries, args.k, args.A, args.presets,
                            configs, args.lookup, scenes=p.root / "scenes")
    table = markdown(rows)
    print(table)
    if args.markdown:
        args.markdown.write_text(table + "\n")
    if args.json:
        ea.save_rows(args.json, __file__, argv, rows,
                     machine={"platform": platform.platform(), "python": platform.python_version(),
                              "cpus": os.cpu_count()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
