"""Time lookup variants side by side, interleaved, on one photon map and query raster.

Each spec is ``VARIANT[@WIDTH]`` or ``floor:VARIANT[@WIDTH]`` (the fetch-only shader of
that variant); WIDTH is the queries per viewport row (default: the raster's side).  After
one warm-up draw of every program, the specs are drawn in turn, one draw each, for
``--rounds`` rounds, so that the machine's load changes hit every spec alike; medians,
minima and ratios to the first spec are printed (wall time: on llvmpipe the GL timer
query misses most of the draw; ``--clock gpu`` on a GPU).

    python tools/bench_variants.py --photons 200000 --queries 65536 \\
        binary-branch-on-packed binary-set-on-packed binary-set-on-merge floor:binary-set-on-packed
"""

from __future__ import annotations

import statistics

import numpy as np

from blockhash import BlockHashIndex
from blockhash.evaluate.datasets import DISTRIBUTIONS
from blockhash.gl.lookup import GLLookup
from blockhash.studies.command import ToolParser, count
from blockhash.studies.shaders.bench import device_info, make_queries


def main(argv=None) -> int:
    ap = ToolParser(__doc__, __file__)
    ap.add_argument("specs", nargs="+", help="VARIANT[@WIDTH] or floor:VARIANT[@WIDTH]")
    ap.photons(200_000)
    ap.add_argument("--queries", type=count, default=65_536, help="queries (default 65,536)")
    ap.add_argument("--k", type=count, default=50)
    ap.add_argument("--A", type=count, default=8)
    ap.add_argument("--data", choices=sorted(DISTRIBUTIONS), default="caustic")
    ap.add_argument("--rounds", type=count, default=8)
    ap.add_argument("--clock", choices=("wall", "gpu"), default="wall")
    args = ap.parse_args(argv)
    args.specs = list(dict.fromkeys(args.specs))  # a spec given twice is timed once
    pts = DISTRIBUTIONS[args.data](args.photons, np.random.default_rng(0))
    q = make_queries(pts, args.queries, "image", 1, args.data)
    side = int(np.ceil(np.sqrt(args.queries)))
    index = BlockHashIndex(pts, k=args.k, A=args.A)
    lookup = GLLookup(index)
    dev = device_info(lookup.ctx)
    print(f"{dev['renderer']} | {dev['gl_version']} | {dev['cpus']} CPUs | {args.photons:,} photons "
          f"({args.data}), {args.queries:,} image-raster queries, k={args.k}, A={args.A}; {index.params!r}")

    def draw(spec: str, warmup: int) -> float:
        name, _, width = spec.partition("@")
        fetch_only = name.startswith("floor:")
        times = lookup.time_draws(q, args.k, A=args.A, variant=name.removeprefix("floor:"),
                                  fetch_only=fetch_only, repeat=1, warmup=warmup,
                                  width=int(width) if width else side)
        return times[args.clock][0]

    for spec in args.specs:
        draw(spec, 1)
    times = {spec: [] for spec in args.specs}
    for _ in range(args.rounds):
        for spec in args.specs:
            times[spec].append(draw(spec, 0))
    base = statistics.median(times[args.specs[0]])
    print(f"{'spec':<44} {'median ms':>10} {'min ms':>9} {'ratio':>6}   ({args.clock} time, "
          f"{args.rounds} rounds)")
    for spec, t in times.items():
        med = statistics.median(t)
        print(f"{spec:<44} {1e3 * med:>10.1f} {1e3 * min(t):>9.1f} {med / base:>6.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
