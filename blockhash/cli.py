"""The ``blockhash`` command line.

``blockhash index`` builds a Block Hashing index over a photon set (synthetic
or a ``.npy`` file of (n, 3) positions), prints its statistics and build times,
and measures its accuracy against exact k nearest neighbours (scipy cKDTree).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from . import __version__
from .bench import QUERY_SETS
from .index.datasets import DISTRIBUTIONS
from .errors import BlockHashError, InputError
from .index.block_hash_index import BlockHashIndex
from .index.metrics import accuracy, exact_knn
from .index.params import PRESETS


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


def cmd_info(args) -> int:
    from .gl.context import get_context, gl_info

    ctx = get_context(args.backend)
    with ctx:
        info = gl_info(ctx)
    width = max(len(k) for k in info)
    for key, value in info.items():
        print(f"{key:<{width}}  {value}")
    return 0


def cmd_bench(args) -> int:
    from .bench import format_table, run_benchmark, run_caustic_benchmark, write_results

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
                             clock=args.clock, progress=log)
    if args.caustic:
        rows += run_caustic_benchmark(args.caustic, photons=args.caustic_photons, A=args.caustic_A,
                                      variant=args.variants.split(",")[0], repeat=args.repeat,
                                      warmup=args.warmup, backend=args.backend, clock=args.clock,
                                      progress=log)
    if rows:
        print(format_table(rows, args.queries))
    if args.json:
        write_results(rows, args.json)
    return 0


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected WIDTHxHEIGHT such as 512x512") from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"--size {text!r}: width and height must be positive")
    return w, h


def cmd_render(args) -> int:
    from .render.images import write_exr, write_png
    from .render.pipeline import render_scene
    from .render.scene_toml import load_scene

    scene = load_scene(args.scene)
    out = Path(args.output or Path(args.scene).with_suffix(".exr").name)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = render_scene(scene, photons=args.photons, k=args.k, A=args.A, method=args.method,
                              variant=args.variant, size=args.size, seed=args.seed,
                              backend=args.backend, progress=True)
    for w in caught:
        print(f"WARNING: {w.message}", file=sys.stderr)
    write_exr(out, result.layers())
    png = out.with_suffix(".png")
    write_png(png, result.combined)
    info = result.info
    print(f"scene: {args.scene} -> {out} (+ {png.name})")
    print(f"photons stored: {info.get('photons_stored', 0):,} of {info.get('photons_emitted', 0):,} emitted")
    if "index" in info:
        print(info["index"])
    print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items()))
    return 0


def cmd_compare(args) -> int:
    from .render.images import compare_images

    results = compare_images(args.a, args.b, diff_path=args.diff)
    print(f"{'layer':<10} {'rms':>12} {'relative rms':>13} {'max':>12}")
    for layer, r in results.items():
        print(f"{layer:<10} {r['rms']:>12.6g} {r['relative_rms']:>13.6g} {r['max']:>12.6g}")
    if args.diff:
        print(f"difference image: {args.diff}")
    return 0


def cmd_preview(args) -> int:
    from .render.images import write_rgb8
    from .render.preview import preview
    from .render.scene_toml import load_scene

    scene = load_scene(args.scene)
    colour, _ = preview(scene, size=args.size)
    out = Path(args.output or Path(args.scene).with_suffix(".preview.png").name)
    h, w, _ = colour.shape
    write_rgb8(out, colour)
    print(f"preview of {args.scene}: {out} ({w} x {h}, pyrender)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="blockhash", description="Low latency photon mapping with Block Hashing.")
    parser.add_argument("--version", action="version", version=f"blockhash {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
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
    p = sub.add_parser("info", help="OpenGL renderer, version, backend and limits",
                       description="Create the offscreen OpenGL context and print what it offers.")
    p.add_argument("--backend", choices=("auto", "egl", "osmesa"), default=None,
                   help="GL backend (default: $BLOCKHASH_GL or auto: EGL, then OSMesa)")
    p.set_defaults(func=cmd_info)
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
    p.add_argument("--variants", default="default",
                   help="comma-separated shader variants (see blockhash.gl.shaderlib.variants())")
    p.add_argument("--data", choices=sorted(DISTRIBUTIONS), default="caustic")
    p.add_argument("--repeat", type=int, default=10, help="timed draws per program (default 10)")
    p.add_argument("--warmup", type=int, default=2,
                   help="untimed draws of the timed program first (default 2)")
    p.add_argument("--clock", choices=("auto", "gpu", "wall"), default="auto",
                   help="time the ratios compare: GL timer queries (gpu) or wall time; auto: "
                        "wall on llvmpipe, whose timer queries miss most of a draw, gpu elsewhere")
    p.add_argument("--caustic", metavar="SCENE",
                   help="also time the caustic pass of SCENE (e.g. scenes/ring.toml) per stage")
    p.add_argument("--caustic-photons", type=int, help="photons to store for --caustic "
                                                         "(default: the scene's)")
    p.add_argument("--caustic-A", type=int, help="A of the --caustic pass (default: the scene's)")
    p.add_argument("--backend", choices=("auto", "egl", "osmesa"), default=None)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-kdtree", action="store_true", help="skip the exact kd-tree shader")
    p.add_argument("--query-set", choices=QUERY_SETS, default="image",
                   help="image: a 512x512-style raster over the receiver (default); "
                        "random: fresh photon-distribution samples in random order")
    p.add_argument("--json", help="write every row to this JSON file")
    p.set_defaults(func=cmd_bench)
    p = sub.add_parser("render", help="render a scene's direct light and caustics to EXR and PNG",
                       description="Trace caustic photons, build the Block Hashing index, render "
                                   "direct light and the caustic pass; write a multi-layer EXR "
                                   "(direct, caustic, combined) and a tone-mapped PNG.")
    p.add_argument("scene", help="scene file (TOML), e.g. scenes/ring.toml")
    p.add_argument("-o", "--output", help="EXR path (default: SCENE-NAME.exr here)")
    p.add_argument("--photons", type=int, help="caustic photons to store (default: the scene's)")
    p.add_argument("--k", type=int, help="photons per estimate (default: the scene's)")
    p.add_argument("--A", type=int, help="accuracy multiplier (default: the scene's)")
    p.add_argument("--method", choices=("bh", "kdtree", "cpu"), default="bh",
                   help="bh: Block Hashing shader; kdtree: exact kNN (kd-tree shader); cpu: BH CPU reference")
    p.add_argument("--variant", default="default", help="BH shader variant")
    p.add_argument("--size", type=_size, help="image size WIDTHxHEIGHT (default: the camera's)")
    p.add_argument("--seed", type=int, help="photon seed (default: the scene's)")
    p.add_argument("--backend", choices=("auto", "egl", "osmesa"), default=None)
    p.set_defaults(func=cmd_render)
    p = sub.add_parser("compare", help="RMS, relative RMS and max error per layer of two images",
                       description="Compare two EXR images layer by layer (OpenImageIO); "
                                   "relative RMS is RMS(A - B) / RMS(B).")
    p.add_argument("a")
    p.add_argument("b", help="the reference")
    p.add_argument("--diff", help="write |A - B| per layer to this EXR")
    p.set_defaults(func=cmd_compare)
    p = sub.add_parser("preview", help="a quick pyrender view of a scene (camera, objects, lights)",
                       description="Render the scene with pyrender in a separate process, to check "
                                   "the camera, objects and lights before a real render.")
    p.add_argument("scene")
    p.add_argument("-o", "--output", help="PNG path (default: SCENE-NAME.preview.png here)")
    p.add_argument("--size", type=_size, help="image size WIDTHxHEIGHT (default: the camera's)")
    p.set_defaults(func=cmd_preview)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except BlockHashError as exc:
        print(f"blockhash {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
