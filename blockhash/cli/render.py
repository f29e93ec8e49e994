"""``blockhash render``: render a scene's direct light and caustics to a multi-layer EXR and a
PNG; ``--time-budget`` and ``--target-error`` choose the photons, k and A from the scene's trade
study.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

from blockhash.cli.args import size as _size
from blockhash.cli.estimate import add_arguments as add_estimate_arguments
from blockhash.cli.estimate import options_from
from blockhash.errors import InputError
from blockhash.frame.options import METHODS
from blockhash.gl.context import BACKENDS
from blockhash.scene.camera import DEFAULT_SPP
from blockhash.validate import writable_path


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


def add_render(sub) -> None:
    """Add ``render`` to the subcommands ``sub``."""
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
