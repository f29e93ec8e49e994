"""False negatives at every k, for each lookup of the default preset (CPU reference).

``tools/eval_accuracy.py``'s measurement (its maps, query sets and split into near and far
queries) repeated over k and the lookups: the walk (the default), the tables hashed
with the walk off, and the Hilbert cells.  One table per lookup and A: the mean false
negatives as a share of k, per map and k.

    python tools/accuracy_by_k.py --json docs/accuracy-by-k.json      # N = 10^5, 4,000 queries
    python tools/accuracy_by_k.py --from-json docs/accuracy-by-k.json  # the tables again
"""

from __future__ import annotations

from blockhash.studies.command import ToolParser
from blockhash.studies.lookups import accuracy_runs as ea

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
    p = ToolParser(__doc__, __file__)
    ea.run_options(p, k=KS)
    p.add_argument("--lookups", type=ea.one_of(*LOOKUPS), default=list(LOOKUPS),
                   help=f"lookups (default {','.join(LOOKUPS)})")
    ea.rows_options(p)
    a = p.parse_args(argv)
    if a.from_json:
        print(tables(ea.saved_rows(a.from_json)))
        return 0
    rows = []
    for lookup in a.lookups:
        for k in a.k:
            for name in a.maps:
                rows += ea.evaluate(name, a.photons, a.queries, k, a.A, ("default",),
                                    lookup=lookup, scenes=p.root / "scenes")
    print(tables(rows))
    if a.json:
        ea.save_rows(a.json, __file__, argv, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
