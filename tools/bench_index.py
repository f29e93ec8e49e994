"""Benchmark the Block Hashing index (CPU reference) against scipy's cKDTree.

For each photon count N this script
  * draws N photons from a synthetic distribution (``--data``, default the
    caustic-like ring caustic) with ``default_rng(seed)``, and ``--queries``
    query points as fresh samples of the same distribution with
    ``default_rng(seed + 1)``;
  * times, interleaved within each repeat, the BH build (default preset,
    builder 'bulk') and the cKDTree build of the same positions, plus one BH
    build with builder 'btree';
  * for each A, times the BH query of all query points (default preset: one
    index per N queried with ``A=``; paper preset: one index per A, because its
    B depends on A) interleaved with the cKDTree query (``workers=-1``, same k);
  * measures accuracy against exact kNN on the index's decoded positions
    (paper section 6): false negatives, maximum and average distance dilation.

Timings are medians over ``--repeat`` runs; ratios are ratios of medians taken
in the same run.  numba compile time is excluded by a warm-up on a tiny input.

    python tools/bench_index.py --quick
    python tools/bench_index.py --sizes 100000,1000000,2000000 --json bench.json
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import platform
import sys
import time
import warnings
from statistics import median

import numpy as np
from scipy.spatial import cKDTree

from blockhash import BlockHashIndex, OrphanWarning
from blockhash.index.datasets import DISTRIBUTIONS
from blockhash.index.metrics import accuracy, exact_knn

PRESETS = ("default", "paper")


def int_list(text: str) -> list[int]:
    return [int(float(v)) for v in text.split(",") if v.strip()]


def timed(fn):
    """(seconds, result) of one call."""
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def build(positions, **kw) -> BlockHashIndex:
    """A BH index; the orphan warning is recorded in the stats, not printed."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OrphanWarning)
        return BlockHashIndex(positions, **kw)


def warm_up(gen, k: int) -> None:
    """Compile every numba path (both builders, both presets, query) on a tiny input."""
    pts = gen(max(2_000, 20 * k), np.random.default_rng(12345))
    for preset in PRESETS:
        for builder in ("bulk", "btree"):
            build(pts, k=k, A=2, preset=preset, builder=builder).query(pts[:64])
    cKDTree(pts).query(pts[:64], k=k, workers=-1)


def stats_dict(stats) -> dict:
    d = {f.name: getattr(stats, f.name) for f in dataclasses.fields(stats) if f.name != "params"}
    d.update(params=repr(stats.params), P=list(stats.params.P), L=stats.params.L, B=stats.params.B,
             overhead=stats.overhead, overhead_with_priority=stats.overhead_with_priority,
             index_bytes=stats.index_bytes)
    return d


def bench_size(n: int, args, gen) -> dict:
    photons = gen(n, np.random.default_rng(args.seed))
    queries = gen(args.queries, np.random.default_rng(args.seed + 1))
    k = args.k
    # Builds: BH default/bulk and cKDTree alternate in each repeat.
    bh_build, kd_build = [], []
    for _ in range(args.repeat):
        t, index = timed(lambda: build(photons, k=k, A=max(args.A), preset="default"))
        bh_build.append(t)
        t, tree = timed(lambda: cKDTree(photons))
        kd_build.append(t)
    btree_s, btree_index = timed(lambda: build(photons, k=k, A=max(args.A), builder="btree"))
    same_blocks = bool(np.array_equal(btree_index.starts, index.starts)
                       and np.array_equal(btree_index.order, index.order))
    del btree_index
    paper, paper_build = {}, {}
    for A in args.A:
        paper_build[A], paper[A] = timed(lambda: build(photons, k=k, A=A, preset="paper"))
    # Exact neighbours on the decoded positions, so quantization is not counted as error.
    decoded = index.positions
    for A in args.A:
        if not np.array_equal(paper[A].positions, decoded):
            raise RuntimeError("paper and default presets decode positions differently")
    exact = exact_knn(decoded, queries, k)
    result = {
        "N": n, "kd_build_s": kd_build, "bh_build_s": bh_build, "btree_build_s": btree_s,
        "btree_same_blocks": same_blocks, "kd_build_median": median(kd_build),
        "bh_build_median": median(bh_build),
        "build_ratio": median(bh_build) / median(kd_build),
        "bh_build_stages": index.timings, "rows": [],
    }
    for A in args.A:
        times = {"kd": [], "default": [], "paper": []}
        answers, counters = {}, {}
        for _ in range(args.repeat):
            t, _ = timed(lambda: tree.query(queries, k=k, workers=-1))
            times["kd"].append(t)
            for preset, ix in (("default", index), ("paper", paper[A])):
                t, answers[preset] = timed(lambda: ix.query(queries, A=A))
                times[preset].append(t)
                counters[preset] = dict(ix.counters)
        kd_q = median(times["kd"])
        for preset in PRESETS:
            ix = index if preset == "default" else paper[A]
            acc = accuracy(answers[preset], exact, n)
            b = median(bh_build) if preset == "default" else paper_build[A]
            q = median(times[preset])
            result["rows"].append({
                "N": n, "preset": preset, "A": A, "params": repr(ix.params),
                "build_s": b, "build_ratio": b / median(kd_build),
                "query_s": times[preset], "query_median": q,
                "kd_query_s": times["kd"], "kd_query_median": kd_q, "query_ratio": q / kd_q,
                "counters": counters[preset], "stats": stats_dict(ix.stats),
                "fn_pct_k": 100.0 * acc.fn_fraction,
                "fn_p90_pct_k": 100.0 * acc.false_negatives["p90"] / k,
                "short_pct": 100.0 * acc.max_dilation["infinite"] / acc.queries,
                "false_negatives": acc.false_negatives, "max_dilation": acc.max_dilation,
                "avg_dilation": acc.avg_dilation,
            })
        print(f"  N={n:,} A={A} done", file=sys.stderr, flush=True)
    return result


HEADER = (f"{'N':>9} {'preset':>7} {'A':>3} {'L':>2} {'P (x,y,z)':>14} {'B':>3} "
          f"{'build s':>8} {'/kd':>5} {'query s':>8} {'kd q s':>7} {'/kd':>5} "
          f"{'FN %k':>6} {'p90':>5} {'<k %':>5} {'maxdil':>7} {'avgdil':>7} {'orph':>6} {'ref/ph':>6} {'ovh':>6}")


def row_line(r: dict) -> str:
    s = r["stats"]
    P = "(" + ",".join(str(p) for p in s["P"]) + ")"
    return (f"{r['N']:>9,} {r['preset']:>7} {r['A']:>3} {s['L']:>2} {P:>14} {s['B']:>3} "
            f"{r['build_s']:>8.3f} {r['build_ratio']:>5.2f} {r['query_median']:>8.3f} "
            f"{r['kd_query_median']:>7.3f} {r['query_ratio']:>5.2f} "
            f"{r['fn_pct_k']:>6.1f} {r['fn_p90_pct_k']:>5.1f} {r['short_pct']:>5.1f} {r['max_dilation']['mean']:>7.4f} "
            f"{r['avg_dilation']['mean']:>7.4f} {s['orphans']:>6,} {s['refs_per_photon']:>6.2f} "
            f"{s['overhead']:>6.1%}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="Queries are fresh samples of the photon distribution.")
    ap.add_argument("--sizes", type=int_list, default=[100_000, 1_000_000, 2_000_000],
                    help="photon counts, comma separated (default 100000,1000000,2000000)")
    ap.add_argument("--queries", type=int, default=262_144, help="query points (default 262144)")
    ap.add_argument("--k", type=int, default=50, help="neighbours per query (default 50)")
    ap.add_argument("--A", type=int_list, default=[1, 2, 4, 8, 16],
                    help="accuracy multipliers, comma separated (default 1,2,4,8,16)")
    ap.add_argument("--data", choices=sorted(DISTRIBUTIONS), default="caustic",
                    help="photon distribution (default caustic)")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per measurement (default 3)")
    ap.add_argument("--seed", type=int, default=0,
                    help="photons use default_rng(seed), queries default_rng(seed + 1)")
    ap.add_argument("--json", metavar="PATH", help="write every number to this JSON file")
    ap.add_argument("--quick", action="store_true",
                    help="smoke test: N=100000, 20000 queries, repeat 1")
    args = ap.parse_args(argv)
    if args.quick:
        args.sizes, args.queries, args.repeat = [100_000], 20_000, 1
    if args.repeat < 1 or args.queries < 1 or args.k < 1 or not args.A or min(args.A) < 1:
        ap.error("--repeat, --queries, --k and every --A must be >= 1")
    gen = DISTRIBUTIONS[args.data]
    t0 = time.perf_counter()
    warm_up(gen, args.k)
    print(f"warm-up (numba compile, excluded) {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    print(f"data {args.data!r} seed {args.seed}; {args.queries:,} queries are fresh samples of the "
          f"photon distribution (seed {args.seed + 1}); k={args.k}; medians of {args.repeat} "
          "interleaved runs; cKDTree query workers=-1")
    print("build/kd = BH build / cKDTree build; query /kd = BH query / cKDTree query; "
          "FN %k = mean false negatives as % of k, p90 = 90th percentile; <k % = queries that found "
          "fewer than k photons; dilations are means over the other queries")
    results = []
    for n in args.sizes:
        r = bench_size(n, args, gen)
        results.append(r)
        print(f"\nN={n:,}: cKDTree build {r['kd_build_median']:.3f} s, BH build (default, bulk) "
              f"{r['bh_build_median']:.3f} s (ratio {r['build_ratio']:.2f}), BH btree build "
              f"{r['btree_build_s']:.3f} s (same blocks: {r['btree_same_blocks']})")
        print(HEADER)
        for row in sorted(r["rows"], key=lambda x: (PRESETS.index(x["preset"]), x["A"])):
            print(row_line(row))
        sys.stdout.flush()
    if args.json:
        meta = {"date": datetime.datetime.now().isoformat(timespec="seconds"),
                "command": " ".join(sys.argv), "python": platform.python_version(),
                "machine": platform.machine(), "numpy": np.__version__,
                "config": {k: v for k, v in vars(args).items() if k != "json"},
                "queries_are": "fresh samples of the photon distribution (seed + 1)"}
        with open(args.json, "w") as f:
            json.dump({"meta": meta, "results": results}, f, indent=1)
        print(f"\nwrote {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
