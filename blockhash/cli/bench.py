"""``blockhash bench``: time Block Hashing shader variants against exact kNN, and the stages of
a scene's caustic pass (``--caustic``); the measuring itself is :mod:`blockhash.studies.shaders.bench`.
"""

from __future__ import annotations

import sys

from blockhash.errors import InputError
from blockhash.evaluate.datasets import DISTRIBUTIONS
from blockhash.gl.context import BACKENDS
from blockhash.studies.shaders.bench import PEERS as CAUSTIC_PEERS
from blockhash.studies.shaders.bench import QUERY_SETS


def cmd_bench(args) -> int:
    from blockhash.studies.shaders.bench import (
        format_table,
        run_benchmark,
        run_caustic_benchmark,
        write_results,
    )

    if args.repeat < 1 or args.warmup < 0:
        raise InputError(f"--repeat {args.repeat} / --warmup {args.warmup}: need at least one "
                         "timed draw and no negative warm-up")
    A_values = tuple(int(a) for a in args.A.split(","))
    log = lambda s: print(s, file=sys.stderr)  # noqa: E731
    rows = []
    if args.queries > 0:
        rows = run_benchmark(photons=args.photons, queries=args.queries, k=args.k, A_values=A_values,
                             variants=tuple(args.variants.split(",")), data=args.data,
                             repeat=args.repeat, warmup=args.warmup, backend=args.backend,
                             seed=args.seed, kdtree=not args.no_kdtree, query_set=args.query_set,
                             clock=args.clock, hashing=args.hashing, progress=log)
    if args.caustic:
        rows += run_caustic_benchmark(args.caustic, photons=args.caustic_photons, A=args.caustic_A,
                                      variant=args.variants.split(",")[0], repeat=args.repeat,
                                      warmup=args.warmup, backend=args.backend, clock=args.clock,
                                      estimates=tuple(e for e in args.caustic_estimates.split(",") if e),
                                      gathers=tuple(g for g in args.caustic_gathers.split(",") if g),
                                      progress=log)
    if rows:
        print(format_table(rows, args.queries))
    if args.json:
        write_results(rows, args.json)
    return 0


def add_bench(sub) -> None:
    """Add ``bench`` to the subcommands ``sub``."""
    p = sub.add_parser("bench", help="time shader variants against exact kNN",
                       description="Time Block Hashing shader variants at each A beside the "
                                   "fetch-only floor, the exact kd-tree shader and cKDTree, on one "
                                   "photon map and query set; min and median of --repeat "
                                   "back-to-back draws after --warmup draws of the same program, "
                                   "GPU time (GL timer queries) beside wall time, with the GL "
                                   "renderer and version.  --caustic SCENE also times the stages "
                                   "of the scene's caustic pass.")
    p.add_argument("--photons", type=int, default=1_000_000)
    p.add_argument("--queries", type=int, default=512 * 512,
                   help="query points (0: skip the lookup benchmark, e.g. with --caustic)")
    p.add_argument("--k", type=int, default=50)
    p.add_argument("--A", default="1,2,4,8,16", help="comma-separated multipliers")
    p.add_argument("--variants", "--variant", dest="variants", default="default",
                   help="comma-separated shader variants (see blockhash.gl.shaderlib.variants())")
    p.add_argument("--data", choices=sorted(DISTRIBUTIONS), default="caustic")
    p.add_argument("--repeat", type=int, default=10, help="timed draws per program (default 10)")
    p.add_argument("--warmup", type=int, default=2,
                   help="untimed draws of the timed program first (default 2)")
    p.add_argument("--clock", choices=("auto", "gpu", "wall"), default="auto",
                   help="time the ratios compare: GL timer queries (gpu) or wall time; auto: "
                        "wall on llvmpipe, whose timer queries miss most of a draw, gpu elsewhere")
    p.add_argument("--hashing", action="store_true",
                   help="also time each variant on the same index's Hilbert cells and with the "
                        "nearest-box-first walk off (the tables hashed and probed), side by "
                        "side, each with its fetch-only floor")
    p.add_argument("--caustic", metavar="SCENE",
                   help="also time the caustic pass of SCENE (e.g. scenes/ring.toml) per stage")
    p.add_argument("--caustic-photons", type=int, help="photons to store for --caustic "
                                                         "(default: the scene's)")
    p.add_argument("--caustic-A", type=int, help="A of the --caustic pass (default: the scene's)")
    p.add_argument("--caustic-estimates", default="", metavar="LIST",
                   help="also time the whole --caustic pass with each of these estimate forms "
                        "(e.g. unbiased,conserving), side by side in the same run")
    p.add_argument("--caustic-gathers", default=",".join(CAUSTIC_PEERS), metavar="LIST",
                   help="the --caustic pass's peers, timed side by side (default: all of "
                        f"{','.join(CAUSTIC_PEERS)}; cover is the default render's gather)")
    p.add_argument("--backend", choices=BACKENDS, default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-kdtree", action="store_true", help="skip the exact kd-tree shader")
    p.add_argument("--query-set", choices=QUERY_SETS, default="image",
                   help="image: a 512x512-style raster over the receiver (default); "
                        "random: fresh photon-distribution samples in random order")
    p.add_argument("--json", help="write every row to this JSON file")
    p.set_defaults(func=cmd_bench)
