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

from blockhash import __version__
from blockhash.bench import GATHERS as CAUSTIC_GATHERS
from blockhash.bench import QUERY_SETS
from blockhash.cli_estimate import add_arguments as add_estimate_arguments
from blockhash.cli_estimate import options_from
from blockhash.cli_images import add_parsers as add_image_parsers
from blockhash.cli_images import size as _size
from blockhash.cli_mitsuba import add_parsers as add_mitsuba_parsers
from blockhash.cli_tradeoff import add_parser as add_tradeoff_parser
from blockhash.errors import BlockHashError, InputError
from blockhash.evaluate.datasets import DISTRIBUTIONS
from blockhash.evaluate.metrics import accuracy, exact_knn
from blockhash.frame.options import METHODS
from blockhash.gl.context import BACKENDS
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.tables.params import PRESETS
from blockhash.scene.camera import DEFAULT_SPP
from blockhash.validate import writable_path


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
    from blockhash.gl.context import get_context, gl_info

    ctx = get_context(args.backend)
    from blockhash.gl.limits import LOOP_LIMIT, MAX_K, is_llvmpipe

    with ctx:
        info = gl_info(ctx)
    info["lookup MAX_K"] = MAX_K
    info["lookup loop limit"] = (f"{LOOP_LIMIT:,} iterations (llvmpipe; bounds A*k)" if is_llvmpipe(ctx)
                                 else "none")
    width = max(len(k) for k in info)
    for key, value in info.items():
        print(f"{key:<{width}}  {value}")
    return 0


def cmd_bench(args) -> int:
    from blockhash.bench import format_table, run_benchmark, run_caustic_benchmark, write_results

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


def cmd_render(args) -> int:
    from blockhash.frame.images import write_exr, write_png
    from blockhash.frame.pipeline import render_scene
    from blockhash.scene.loader import load_scene

    out = Path(args.output or Path(args.scene).with_suffix(".exr").name)
    if out.suffix.lower() != ".exr":
        raise InputError(f"--output {out}: expected a .exr file name (the PNG preview is written "
                         "beside it)")
    writable_path(out, "--output")
    scene = load_scene(args.scene)
    if args.time_budget is not None or args.target_error is not None:
        _choose_settings(args, scene)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = render_scene(scene, photons=args.photons, k=args.k, A=args.A, method=args.method,
                              variant=args.variant, size=args.size, seed=args.seed,
                              backend=args.backend, progress=True, options=options_from(args),
                              spp=args.spp)
    for w in caught:
        print(f"WARNING: {w.message}", file=sys.stderr)
    write_exr(out, result.layers(), {"blockhash:spp": result.spp})
    png = out.with_suffix(".png")
    write_png(png, result.combined)
    info = result.info
    print(f"scene: {args.scene} -> {out} (+ {png.name})")
    print(f"photons stored: {info.get('photons_stored', 0):,} of {info.get('photons_emitted', 0):,} emitted")
    print(f"density estimate: {info.get('estimate')}; {result.spp} samples per pixel")
    if "index" in info:
        print(info["index"])
    print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items()))
    return 0


def _choose_settings(args, scene) -> None:
    """Fill args.photons, k, A from the scene's trade study for --time-budget / --target-error."""
    if not scene.specular_objects:
        print("settings: the scene has no specular object, so no caustic photons are traced and "
              "no index is built; the budget applies to nothing")
        return
    from blockhash.studies.budget import choose, study_for

    if args.photons is not None or args.k is not None or args.A is not None:
        raise InputError("--time-budget / --target-error choose --photons, --k and --A; give "
                         "either those or a budget, not both")
    cache = Path(args.cache) if args.cache else Path.home() / ".cache" / "blockhash"
    study = study_for(scene, cache_dir=cache, study_path=args.tradeoff, backend=args.backend,
                      progress=lambda s: print(s, file=sys.stderr))
    w, h = args.size or (scene.camera.width, scene.camera.height)
    choice = choose(study, pixels=w * h, time_budget=args.time_budget,
                    target_error=args.target_error)
    args.photons, args.k, args.A = choice.photons, choice.k, choice.A
    print(f"settings: photons {choice.photons:,}, k {choice.k}, A {choice.A}: {choice.reason}; "
          f"predicted {choice.predicted_seconds:.2f} s for trace + index + caustic pass, relative "
          f"RMS {choice.predicted_error:.3f} against the reference (2 px blur, at the study's "
          f"{study['size'][0]} x {study['size'][1]})")


def cmd_preview(args) -> int:
    from blockhash.frame.images import write_rgb8
    from blockhash.scene.loader import load_scene
    from blockhash.scene.preview import preview

    out = writable_path(Path(args.output or Path(args.scene).with_suffix(".preview.png").name), "--output")
    scene = load_scene(args.scene)
    colour, _ = preview(scene, size=args.size)
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
    p.add_argument("--backend", choices=BACKENDS, default=None,
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
    p.add_argument("--caustic-gathers", default=",".join(CAUSTIC_GATHERS), metavar="LIST",
                   help="the --caustic pass's peers, timed side by side (default: all of "
                        f"{','.join(CAUSTIC_GATHERS)}; cover is the default render's gather)")
    p.add_argument("--backend", choices=BACKENDS, default=None)
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
    p.add_argument("scene", help="scene file (TOML, or Mitsuba 3 XML), e.g. scenes/ring.toml")
    p.add_argument("-o", "--output", help="EXR path (default: SCENE-NAME.exr here)")
    p.add_argument("--photons", type=int, help="caustic photons to store (default: the scene's)")
    p.add_argument("--k", type=int, help="photons per estimate (default: the scene's)")
    p.add_argument("--A", type=int, help="accuracy multiplier (default: the scene's)")
    p.add_argument("--method", choices=METHODS, default="auto",
                   help="auto (default): cover for the conserving estimate, else bh; cover: every "
                        "photon whose own disc covers the point (shader); bh: the k nearest by "
                        "Block Hashing (shader); kdtree: exact kNN (kd-tree shader); cpu: the CPU "
                        "reference of what auto picks")
    p.add_argument("--variant", default="default", help="BH shader variant")
    p.add_argument("--size", type=_size, help="image size WIDTHxHEIGHT (default: the camera's)")
    p.add_argument("--spp", type=int, help="samples per pixel, a square number (stratified "
                   "jitter, box filter; default: the scene's [camera] spp, else "
                   f"{DEFAULT_SPP})")
    p.add_argument("--seed", type=int, help="photon seed (default: the scene's)")
    p.add_argument("--backend", choices=BACKENDS, default=None)
    p.add_argument("--time-budget", type=float, metavar="SECONDS",
                   help="choose photons, k and A from the scene's trade study: least error that fits")
    p.add_argument("--target-error", type=float, metavar="E",
                   help="choose the fastest setting whose relative RMS against the reference is <= E")
    p.add_argument("--tradeoff", help="tradeoff.json to choose from (default: the cached study of "
                   "this scene, else a short calibration run)")
    p.add_argument("--cache", help="cache directory (default ~/.cache/blockhash)")
    add_estimate_arguments(p)
    p.set_defaults(func=cmd_render)
    add_tradeoff_parser(sub)
    add_image_parsers(sub)
    add_mitsuba_parsers(sub)
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
    except OSError as exc:  # a file the checks above did not foresee: one line, no traceback
        where = f" {exc.filename}" if exc.filename else ""
        print(f"blockhash {args.command}: error:{where} {exc.strerror or exc}; check the path and "
              "its permissions", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
