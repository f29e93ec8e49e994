"""``blockhash index``: build a Block Hashing index over a photon set (synthetic or a ``.npy``
file of (n, 3) positions), print its statistics and build times, and measure its accuracy
against exact k nearest neighbours (scipy cKDTree).
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np

from blockhash.errors import InputError
from blockhash.evaluate.datasets import DISTRIBUTIONS
from blockhash.evaluate.metrics import accuracy, exact_knn
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.tables.params import PRESETS


def _load_photons(spec: str, n: int, seed: int) -> np.ndarray:
    if spec in DISTRIBUTIONS:
        return DISTRIBUTIONS[spec](n, np.random.default_rng(seed))
    path = Path(spec)
    if path.suffix != ".npy":
        raise InputError(f"--data {spec!r} is neither a distribution ({', '.join(DISTRIBUTIONS)}) "
                         "nor a .npy file of (n, 3) positions")
    if not path.is_file():
        raise InputError(f"--data {spec!r}: no such file; give a .npy file of (n, 3) positions")
    return np.load(path)


def cmd_index(args) -> int:
    photons = _load_photons(args.data, args.photons, args.seed)
    print(f"photons: {len(photons):,} from {args.data!r} (seed {args.seed})")
    t = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        index = BlockHashIndex(photons, k=args.k, A=args.A, preset=args.preset, builder=args.builder)
    print(f"build: {time.perf_counter() - t:.2f} s ("
          + ", ".join(f"{name} {sec:.2f}" for name, sec in index.timings.items() if name != "total")
          + ")")
    print(index.stats.summary())
    for w in caught:
        print(f"WARNING: {w.message}", file=sys.stderr)
    if args.queries:
        rng = np.random.default_rng(args.seed + 1)
        if args.data in DISTRIBUTIONS:
            queries = DISTRIBUTIONS[args.data](args.queries, rng)
        else:
            queries = photons[rng.integers(0, len(photons), args.queries)]
        t = time.perf_counter()
        approx = index.query(queries, k=args.k)
        tq = time.perf_counter() - t
        t = time.perf_counter()
        exact = exact_knn(index.positions, queries, args.k)
        te = time.perf_counter() - t
        if args.k == 1:
            approx = tuple(a[:, None] for a in approx)
        acc = accuracy(approx, exact, len(index))
        print(f"query: {len(queries):,} points in {tq:.2f} s (CPU reference), exact cKDTree {te:.2f} s; "
              f"{index.counters['query.candidates.mean']:.0f} candidates, "
              f"{index.counters['query.blocks.mean']:.1f} blocks per query")
        print(f"accuracy: false negatives {acc.fn_fraction:.1%} of k (p90 "
              f"{acc.false_negatives['p90'] / args.k:.0%}), max dilation mean "
              f"{acc.max_dilation['mean']:.3f}, average dilation mean {acc.avg_dilation['mean']:.3f}")
    return 0


def add_index(sub) -> None:
    """Add ``index`` to the subcommands ``sub``."""
    p = sub.add_parser("index", help="build an index over photons, print stats and accuracy",
                       description="Build a Block Hashing index over a photon set, print its "
                                   "statistics and compare queries with exact kNN (cKDTree).")
    p.add_argument("--data", default="caustic",
                   help=f"distribution ({', '.join(DISTRIBUTIONS)}) or a .npy file of (n, 3) "
                        "positions (default: caustic)")
    p.add_argument("--photons", type=int, default=1_000_000, help="photons to generate (default 1e6)")
    p.add_argument("--queries", type=int, default=100_000, help="query points (default 100,000; 0: none)")
    p.add_argument("--k", type=int, default=50, help="neighbours per query (default 50)")
    p.add_argument("--A", type=int, default=8, help="accuracy multiplier (default 8)")
    p.add_argument("--preset", choices=PRESETS, default="default")
    p.add_argument("--builder", choices=("bulk", "btree"), default="bulk")
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=cmd_index)
