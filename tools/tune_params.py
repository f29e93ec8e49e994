"""Sweep the default preset's knobs; report accuracy, memory and build time.

The default preset (:func:`blockhash.index.params.default_params`) turns a photon set
into ``L``, ``P = (Px, Py, Pz)`` and ``B`` with a few constants and heuristics.
This script builds one index per combination of the knob values given on the
command line (the preset's own function with the knobs as keywords, passed to
the index as ``L``, ``P``, ``B`` overrides, nested thresholds) and reports for
each:

* the parameters chosen (``P``, ``B``), the allocated block references per
  photon (``L * buckets * B / N``; the issue's bound is 2.5) and orphans;
* accuracy against exact kNN on the index's decoded positions (paper section
  6): mean false negatives in % of k and their 90th percentile, the mean
  average-distance dilation and the mean maximum-distance dilation, over all
  queries and separately over floor queries (``y == 0``) and off-floor queries
  (``y != 0``; on 'caustic' data the ring's wall);
* BH build time beside cKDTree build time on the same points (medians of
  ``--repeat`` alternating builds; the issue's target is BH <= 2x cKDTree at
  N = 10^6).  On a shared 2-core machine single timings vary by up to 2x: use
  ``--repeat 3`` or more before quoting a ratio.

The first row of each data set, marked ``*``, is the shipped preset
(``default_params`` with no keywords) unless ``--no-baseline``.

Data (``--data``): the names of :data:`blockhash.index.datasets.DISTRIBUTIONS`, and
``caustic-wallNN``: caustic-like photons plus extra photons on the ring's wall
so that NN% of all photons are off the floor (caustic-like alone has 3%).

Queries (``--query-mode``):

``split`` (default)
    one draw of ``N + queries`` points with ``default_rng(seed)``, split into
    the first N (photons) and the rest (queries): independent samples of one
    distribution.
``seed``
    photons ``gen(N, default_rng(seed))``, queries ``gen(queries,
    default_rng(seed + 1))``, as tools/bench_index.py and tests/test_index.py
    draw them.  The generators draw part of their structure from the generator
    ('caustic': the five hot-spot centres and widths; 'clustered': every cluster
    centre, weight and width), so these queries follow a *different*
    distribution: on 'clustered' most land away from every photon cluster, and
    on 'caustic' 15% sit on hot spots that the photons do not have.

Knobs (each takes a comma-separated list; the sweep is their product; the
defaults are the shipped constants of blockhash/index/params.py):

``--ppb``       photons per bucket as a multiple of k        DEFAULT_PHOTONS_PER_BUCKET
``--L``         hash tables                                  DEFAULT_L
``--slack``     B <= slack * photons per bucket / 10          DEFAULT_BLOCK_SLACK
``--refs-cap``  B <= refs-cap * N / (L * buckets)             DEFAULT_REFS_PER_PHOTON
``--plane``     one bucket on an axis where one plane holds
                more than this share (> 1 turns it off)      PLANE_SHARE
``--shape``     strength of balance_nested_shape (0 = off)   SHAPE_STRENGTH
``--pct``       robust-extent percentiles LO-HI              EXTENT_PERCENTILES
``--thin``      buckets given to an axis the preset makes one-bucket (tried, rejected: 1)
``--aspect``    Px multiplied and Pz divided by sqrt(aspect) (tried, superseded by --shape: 1)

With ``--thin`` or ``--aspect`` away from 1, ``B`` is recomputed by the preset's
rule for the changed ``P``.

The old preset (before this tool) is ``--ppb 2 --L 8 --slack 2 --plane 2 --shape 0``.
Commands behind the constants in blockhash/index/params.py (k=50, A=8, N=10^6 unless said;
S = 0 and 3, M = split and seed)::

    # photons per bucket; tables; block slack (caustic-like)
    python tools/tune_params.py --seed S --ppb 1.25,1.75,2
    python tools/tune_params.py --seed S --L 6,8 --no-baseline
    python tools/tune_params.py --seed S --slack 2,2.5,3.5 --no-baseline
    # shape balancing strength: caustic-like and clustered; caustic-like with queries drawn
    # apart (S = 3 and 4)
    python tools/tune_params.py --data caustic,clustered --queries 20000 --shape 0,0.5,1,1.5,2
    python tools/tune_params.py --seed S --query-mode seed --shape 0.5,1
    # plane share: a floor with a lit wall of growing weight (N = 3 x 10^5); the rule
    # on (the * rows) and off, then forced where the floor holds less than half
    python tools/tune_params.py --n 300000 --queries 20000 --plane 2 \\
        --data caustic-wall6,caustic-wall12,caustic-wall25,caustic-wall52,caustic-wall76
    python tools/tune_params.py --data caustic-wall52 --n 300000 --queries 20000 --plane 0.4 --no-baseline
    python tools/tune_params.py --data caustic-wall76 --n 300000 --queries 20000 --plane 0.2 --no-baseline
    # before / after at the issue's target, seeds 0-4, both query modes
    python tools/tune_params.py --seed S --query-mode M --ppb 2 --L 8 --slack 2 --plane 2 --shape 0
    # the other distributions, both k, before / after
    python tools/tune_params.py --data uniform,clustered,planar,caustic --n 100000,1000000 \\
        --k 8,50 --queries 20000 --ppb 2 --L 8 --slack 2 --plane 2 --shape 0
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import re
import sys
import time
import warnings
from contextlib import contextmanager
from statistics import median

import numpy as np
from scipy.spatial import cKDTree

from blockhash import BlockHashIndex, OrphanWarning
from blockhash.index import params as bp
from blockhash.index.datasets import CAUSTIC_SHARES, DISTRIBUTIONS, caustic_like
from blockhash.index.metrics import dilations, exact_knn, false_negatives

WALL = re.compile(r"caustic-wall(\d+(?:\.\d+)?)$")


def caustic_with_wall(share: float):
    """Generator: caustic-like photons plus ring-wall photons, ``share`` of all off the floor."""
    wall0 = CAUSTIC_SHARES[-1]  # caustic_like's own wall share

    def gen(n: int, rng: np.random.Generator) -> np.ndarray:
        if share <= wall0:
            return caustic_like(n, rng)
        n_caustic = int(round(n * (1.0 - share) / (1.0 - wall0)))
        extra = n - n_caustic
        t = rng.random(extra) * 2.0 * np.pi
        wall = np.stack([0.5 * np.cos(t), 0.3 * rng.random(extra), 0.5 * np.sin(t)], axis=1)
        p = np.concatenate([caustic_like(n_caustic, rng), wall])
        return p[rng.permutation(n)]
    return gen


def generator(name: str):
    if name in DISTRIBUTIONS:
        return DISTRIBUTIONS[name]
    m = WALL.match(name)
    if m:
        return caustic_with_wall(float(m.group(1)) / 100.0)
    raise argparse.ArgumentTypeError(
        f"unknown data {name!r}; choose from {', '.join(DISTRIBUTIONS)} or caustic-wallNN")


def floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def ints(text: str) -> list[int]:
    return [int(float(v)) for v in text.split(",") if v.strip()]


def names(text: str) -> list[str]:
    out = [v.strip() for v in text.split(",") if v.strip()]
    for v in out:
        generator(v)
    return out


def pct_pairs(text: str) -> list[tuple[float, float]]:
    out = []
    for v in text.split(","):
        lo, hi = v.split("-")
        out.append((float(lo), float(hi)))
    return out


@contextmanager
def extent_percentiles(pct):
    """Temporarily replace blockhash.index.params.EXTENT_PERCENTILES (read at call time)."""
    old = bp.EXTENT_PERCENTILES
    bp.EXTENT_PERCENTILES = tuple(pct)
    try:
        yield
    finally:
        bp.EXTENT_PERCENTILES = old


def recipe(positions, *, k: int, A: int, ppb: float, L: int, slack: float, refs_cap: float,
           plane: float, shape: float, pct, thin: int, aspect: float):
    """(L, P, B): ``default_params`` with the knobs, then the exploratory ``thin``/``aspect``."""
    with extent_percentiles(pct):
        prm = bp.default_params(positions, k=k, A=A, photons_per_bucket=ppb, L=L,
                                refs_per_photon=refs_cap, block_slack=slack,
                                plane_share=plane, shape_strength=shape)
    if thin == 1 and aspect == 1.0:
        return prm.L, prm.P, prm.B
    P = list(prm.P)
    flat = [p == 1 for p in P]
    if thin > 1:
        P = [thin if f else p for p, f in zip(P, flat)]
    if aspect != 1.0 and P[0] > 1 and P[2] > 1:
        s = math.sqrt(aspect)
        P[0], P[2] = max(2, round(P[0] * s)), max(2, round(P[2] / s))
    P = tuple(int(min(p, bp.MAX_P)) for p in P)
    n = len(positions)
    # Photons per bucket count only the axes the preset split: the extra buckets on a
    # thin axis are mostly empty (its photons sit on one side of every threshold).
    live = int(np.prod([p for p, f in zip(P, flat) if not f] or [1]))
    buckets = P[0] * P[1] * P[2]
    B_need = math.ceil(slack * (n / live) / bp.PHOTONS_PER_BLOCK)
    B_budget = max(1, int(refs_cap * n / (L * buckets)))
    return L, P, max(1, min(B_need, B_budget, bp.MAX_B))


def build(positions, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OrphanWarning)
        return BlockHashIndex(positions, **kw)


def timed_builds(positions, repeat: int, **kw):
    """(median BH build s, median cKDTree build s, last index), builds alternating."""
    tb, tk, index = [], [], None
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        cKDTree(positions)
        tk.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        index = build(positions, **kw)
        tb.append(time.perf_counter() - t0)
    return median(tb), median(tk), index


def measure(index, queries, exact, k: int, A: int) -> dict:
    d, i = index.query(queries, A=A)
    fn = false_negatives(i, exact[1], len(index)) / k
    mx, av = dilations(d, exact[0])
    floor = queries[:, 1] == 0
    out = {"candidates": index.counters["query.candidates.mean"],
           "blocks": index.counters["query.blocks.mean"]}
    for part, m in (("all", np.ones(len(queries), bool)), ("floor", floor), ("off", ~floor)):
        if not m.any():
            out[part] = None
            continue
        fin_a, fin_m = np.isfinite(av[m]), np.isfinite(mx[m])
        out[part] = {
            "queries": int(m.sum()),
            "fn": float(fn[m].mean()), "fn_p90": float(np.percentile(fn[m], 90)),
            "avg_dil": float(av[m][fin_a].mean()) if fin_a.any() else math.nan,
            "max_dil": float(mx[m][fin_m].mean()) if fin_m.any() else math.nan,
            "short": int((~fin_m).sum()),
        }
    return out


HEADER = (f"{'data':<9} {'N':>8} {'k':>3} {'ppb':>4} {'L':>2} {'slack':>5} {'cap':>4} {'plane':>5} "
          f"{'shape':>5} {'pct':>5} {'thin':>4} {'asp':>3}  | {'P':<13} {'B':>3} {'refs':>4} {'orph':>4} | "
          f"{'FN%':>5} {'p90':>5} {'avgD':>6} {'maxD':>6} | {'flFN%':>5} {'flAvg':>6} {'flMax':>6} | "
          f"{'offFN%':>6} {'offAvg':>6} {'offMax':>6} | {'BH s':>5} {'kd s':>5} {'x':>4}")


def fmt_row(r: dict) -> str:
    def part(p, width=5):
        if p is None:
            return f"{'-':>{width}} {'-':>6} {'-':>6}"
        return f"{100 * p['fn']:>{width}.1f} {p['avg_dil']:>6.4f} {p['max_dil']:>6.4f}"
    a = r["acc"]["all"]
    P = "x".join(str(p) for p in r["P"])
    mark = "*" if r["baseline"] else " "
    return (f"{r['data']:<9} {r['N']:>8} {r['k']:>3} {r['ppb']:>4g} {r['L']:>2} {r['slack']:>5g} "
            f"{r['refs_cap']:>4g} {r['plane']:>5g} {r['shape']:>5g} {r['pct']:>5} {r['thin']:>4} "
            f"{r['aspect']:>3g} {mark}| {P:<13} {r['B']:>3} {r['refs_per_photon']:>4.2f} "
            f"{r['orphans']:>4} | {100 * a['fn']:>5.1f} {100 * a['fn_p90']:>5.1f} {a['avg_dil']:>6.4f} "
            f"{a['max_dil']:>6.4f} | {part(r['acc']['floor'])} | {part(r['acc']['off'], 6)} | "
            f"{r['build_s']:>5.2f} {r['kd_build_s']:>5.2f} {r['build_ratio']:>4.2f}")


def parse_args(argv=None):
    ap = argparse.ArgumentParser(
        prog="tools/tune_params.py", description=__doc__.split("\n\n")[0],
        epilog=__doc__[__doc__.index("Data ("):], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=names, default=["caustic"],
                    help="data sets, comma-separated (default caustic)")
    ap.add_argument("--n", type=ints, default=[1_000_000], help="photon counts (default 1000000)")
    ap.add_argument("--k", type=ints, default=[50], help="neighbours per query (default 50)")
    ap.add_argument("--A", type=int, default=8, help="accuracy multiplier (default 8)")
    ap.add_argument("--queries", type=int, default=50_000, help="query points (default 50000)")
    ap.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    ap.add_argument("--query-mode", choices=("split", "seed"), default="split",
                    help="how queries are drawn, see below (default split)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="alternating BH / cKDTree builds per row; times are medians (default 1)")
    ap.add_argument("--ppb", type=floats, default=[bp.DEFAULT_PHOTONS_PER_BUCKET],
                    help=f"photons per bucket / k (default {bp.DEFAULT_PHOTONS_PER_BUCKET:g})")
    ap.add_argument("--L", type=ints, default=[bp.DEFAULT_L], help=f"hash tables (default {bp.DEFAULT_L})")
    ap.add_argument("--slack", type=floats, default=[bp.DEFAULT_BLOCK_SLACK],
                    help=f"block slack (default {bp.DEFAULT_BLOCK_SLACK:g})")
    ap.add_argument("--refs-cap", type=floats, default=[bp.DEFAULT_REFS_PER_PHOTON],
                    help=f"cap on references per photon (default {bp.DEFAULT_REFS_PER_PHOTON:g})")
    ap.add_argument("--plane", type=floats, default=[bp.PLANE_SHARE],
                    help=f"plane share making an axis one-bucket, > 1 = off (default {bp.PLANE_SHARE:g})")
    ap.add_argument("--shape", type=floats, default=[bp.SHAPE_STRENGTH],
                    help=f"shape balancing strength, 0 = off (default {bp.SHAPE_STRENGTH:g})")
    lo, hi = bp.EXTENT_PERCENTILES
    ap.add_argument("--pct", type=pct_pairs, default=[(lo, hi)],
                    help=f"robust-extent percentiles LO-HI, comma-separated (default {lo:g}-{hi:g})")
    ap.add_argument("--thin", type=ints, default=[1], help="buckets on a one-bucket axis (default 1)")
    ap.add_argument("--aspect", type=floats, default=[1.0], help="Px/Pz stretch (default 1)")
    ap.add_argument("--no-baseline", action="store_true", help="omit the shipped preset's row")
    ap.add_argument("--json", help="also write all rows to this JSON file")
    return ap.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    # Compile every numba path on a tiny input so that timings exclude it.
    warm = DISTRIBUTIONS["uniform"](4000, np.random.default_rng(1))
    build(warm, k=8, A=2).query(warm[:16])
    cKDTree(warm)

    combos = list(itertools.product(args.ppb, args.L, args.slack, args.refs_cap, args.plane,
                                    args.shape, args.pct, args.thin, args.aspect))
    print(f"A={args.A}, {args.queries:,} queries ({args.query_mode}), seed {args.seed}; FN in % of k; "
          "dilations are means over queries; * = shipped default_params", flush=True)
    print(HEADER, flush=True)
    rows = []
    for data, n, k in itertools.product(args.data, args.n, args.k):
        gen = generator(data)
        if args.query_mode == "split":
            both = gen(n + args.queries, np.random.default_rng(args.seed))
            pts, qs = both[:n], both[n:]
        else:
            pts = gen(n, np.random.default_rng(args.seed))
            qs = gen(args.queries, np.random.default_rng(args.seed + 1))
        exact = None
        for combo in ([None] if not args.no_baseline else []) + combos:
            if combo is None:
                prm = bp.default_params(pts, k=k, A=args.A)
                L, P, B = prm.L, prm.P, prm.B
                knobs = dict(ppb=bp.DEFAULT_PHOTONS_PER_BUCKET, L=bp.DEFAULT_L,
                             slack=bp.DEFAULT_BLOCK_SLACK, refs_cap=bp.DEFAULT_REFS_PER_PHOTON,
                             plane=bp.PLANE_SHARE, shape=bp.SHAPE_STRENGTH,
                             pct=bp.EXTENT_PERCENTILES, thin=1, aspect=1.0)
            else:
                knobs = dict(zip(("ppb", "L", "slack", "refs_cap", "plane", "shape", "pct", "thin",
                                  "aspect"), combo))
                L, P, B = recipe(pts, k=k, A=args.A, **knobs)
            tb, tk, index = timed_builds(pts, args.repeat, k=k, A=args.A, L=L, P=P, B=B,
                                         layout="nested")
            if exact is None:
                exact = exact_knn(index.positions, qs, k)
            st = index.stats
            row = dict(data=data, N=n, k=k, A=args.A, seed=args.seed, query_mode=args.query_mode,
                       baseline=combo is None, **{**knobs, "L": L},
                       P=list(P), B=B, refs_per_photon=st.refs_per_photon, orphans=st.orphans,
                       build_s=tb, kd_build_s=tk, build_ratio=tb / tk,
                       acc=measure(index, qs, exact, k, args.A))
            row["pct"] = f"{row['pct'][0]:g}-{row['pct'][1]:g}"
            rows.append(row)
            print(fmt_row(row), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"argv": sys.argv[1:], "rows": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
