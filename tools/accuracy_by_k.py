"""False negatives at every k, for each lookup of the default preset (CPU reference).

``tools/eval_accuracy.py``'s measurement (its maps, query sets and split into near and far
queries) repeated over k and the lookups: the walk (today's default), the tables hashed
with the walk off, and the Hilbert cells.  One table per lookup and A: the mean false
negatives as a share of k, per map and k.

    python tools/accuracy_by_k.py --json docs/accuracy-by-k.json      # N = 10^5, 4,000 queries
    python tools/accuracy_by_k.py --from-json docs/accuracy-by-k.json  # the tables again
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from blockhash.evaluate import accuracy_runs as ea

SCENES = Path(__file__).resolve().parents[1] / "scenes"

KS = (1, 2, 4, 8, 16, 32, 50, 100, 128)
LOOKUPS = ("walk", "hash", "cells")


def tables(rows) -> str:
    ks = sorted({r["k"] for r in rows})
    maps = list(dict.fromkeys(r["map"] for r in rows))
    out = []
    for lookup in dict.fromkeys(r["lookup"] for r in rows):
        for A in sorted({r["A"] for r in rows}):
            cell = {(r["map"], r["k"]): r for r in rows if r["lookup"] == lookup and r["A"] == A}
            out += [f"**{lookup}, A = {A}** (false negatives, % of k; worst of near / far in "
                    "brackets where far queries exist)", "",
                    "| map | set | " + " | ".join(f"k = {k}" for k in ks) + " |",
                    "|---|---|" + "---|" * len(ks)]
            for name in maps:
                entries = []
                for k in ks:
                    r = cell.get((name, k))
                    if r is None:
                        entries.append("")
                        continue
                    worst = max(r["fn_near"], r["fn_far"]) if r["far_share"] > 0 else r["fn_near"]
                    entries.append(f"{100 * r['fn_mean']:.2f}" + (
                        f" ({100 * worst:.1f})" if r["far_share"] > 0 else ""))
                first = next(r for (m, _), r in cell.items() if m == name)
                out.append(f"| {name} | {first['set']} | " + " | ".join(entries) + " |")
            out.append("")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", default=",".join(ea.TUNE + ea.REPORT))
    ap.add_argument("--photons", type=float, default=1e5)
    ap.add_argument("--queries", type=int, default=4000)
    ap.add_argument("--k", default=",".join(map(str, KS)))
    ap.add_argument("--A", default="8,64")
    ap.add_argument("--lookups", default=",".join(LOOKUPS))
    ap.add_argument("--json", help="write the rows here")
    ap.add_argument("--from-json", metavar="FILE", help="print the tables of a saved run")
    a = ap.parse_args(argv)
    if a.from_json:
        print(tables(json.loads(Path(a.from_json).read_text())["rows"]))
        return 0
    rows = []
    for lookup in a.lookups.split(","):
        for k in (int(x) for x in a.k.split(",")):
            for name in a.maps.split(","):
                rows += ea.evaluate(name, int(a.photons), a.queries, k,
                                    [int(x) for x in a.A.split(",")], ("default",),
                                    lookup=lookup, scenes=SCENES)
    print(tables(rows))
    if a.json:
        Path(a.json).write_text(json.dumps({"command": "python tools/accuracy_by_k.py "
                                            + " ".join(argv or sys.argv[1:]), "rows": rows},
                                           indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
