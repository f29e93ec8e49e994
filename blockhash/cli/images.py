"""The image commands: ``blockhash compare`` (per-layer errors against a reference, with
limits that set the exit status), ``blockhash tolerance`` (limits proposed from the noise between
photon seeds), ``blockhash preview`` (a quick pyrender view of a scene) and ``blockhash info``
(the OpenGL context that renders them).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from blockhash.cli.args import FLAGS, size, size_help
from blockhash.errors import InputError
from blockhash.frame.options import METHODS
from blockhash.gl.context import BACKENDS
from blockhash.validate import writable_path


def _limit(text: str) -> tuple[str, float]:
    """'0.05' -> ('*', 0.05); 'caustic=0.05' -> ('caustic', 0.05)."""
    layer, _, value = text.rpartition("=")
    try:
        number = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a number or LAYER=NUMBER such as "
                                         "caustic=0.05") from None
    if not number >= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: the limit must be a number >= 0")
    return layer or "*", number


def _limits(pairs) -> dict | None:
    return dict(pairs) if pairs else None


def _emit_json(dest: str, data: dict) -> None:
    """Print ``data`` as JSON (``dest`` '-') or write it to the file ``dest``; infinite and NaN
    numbers become the strings "inf", "-inf", "nan" (standard JSON has no such numbers)."""
    import json
    import math

    def finite(x):
        if isinstance(x, float) and not math.isfinite(x):
            return str(x)
        if isinstance(x, dict):
            return {k: finite(v) for k, v in x.items()}
        if isinstance(x, (list, tuple)):
            return [finite(v) for v in x]
        return x

    text = json.dumps(finite(data), indent=2, allow_nan=False)
    if dest == "-":
        print(text)
        return
    try:
        Path(dest).write_text(text + "\n")
    except OSError as exc:
        raise InputError(f"--json {dest}: cannot write it ({exc.strerror}); give a writable path "
                         "or '-' for stdout") from None


def cmd_compare(args) -> int:
    from blockhash.evaluate.imagediff import compare_layers, write_pictures
    from blockhash.evaluate.images import write_exr

    result = compare_layers(args.a, args.b, max_rms=_limits(args.max_rms),
                            max_rel_rms=_limits(args.max_rel_rms), max_flip=_limits(args.max_flip),
                            mask=args.mask)
    # With --json - stdout carries the JSON alone; the table goes to stderr.
    report = sys.stderr if args.json == "-" else sys.stdout
    print(result.table(), file=report)
    if args.diff:
        write_exr(args.diff, {name: np.abs(result.a[name] - result.b[name]) for name in result.a})
        print(f"difference image: {args.diff}", file=report)
    write_pictures(result, heatmap=args.heatmap, strip=args.strip, error=args.error, vmax=args.vmax)
    for what, path in (("heat map", args.heatmap), ("strip (A | B | error)", args.strip)):
        if path:
            print(f"{what}, {args.error} error: {path}", file=report)
    if args.json:
        _emit_json(args.json, result.to_json())
    for failure in result.failures:
        print(f"FAIL {failure.spelled(FLAGS)}", file=sys.stderr)
    if result.limits:
        print("pass: every layer within its limits" if result.passed
              else f"fail: {len(result.failures)} limit(s) exceeded", file=report)
    return 0 if result.passed else 1


def cmd_tolerance(args) -> int:
    from blockhash.evaluate.tolerance import seed_tolerances
    from blockhash.scene.loader import load_scene

    scene = load_scene(args.scene)
    report = seed_tolerances(scene, seeds=args.seeds, first_seed=args.first_seed,
                             photons=args.photons, size=args.size, k=args.k, A=args.A,
                             method=args.method, margin=args.margin, backend=args.backend,
                             progress=lambda s: print(s, file=sys.stderr), spp=args.spp)
    out = sys.stderr if args.json == "-" else sys.stdout
    print(report.table(), file=out)
    print(f"proposed: blockhash compare A.exr B.exr {report.options()}", file=out)
    if args.heatmap:
        from blockhash.evaluate.plots import save_heatmap

        save_heatmap(args.heatmap, report.spread_maps, label="std over seeds",
                     title=f"{args.scene}: per-pixel spread over {args.seeds} seeds")
        print(f"spread map: {args.heatmap}", file=out)
    if args.json:
        _emit_json(args.json, report.to_json())
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


def cmd_preview(args) -> int:
    from blockhash.evaluate.images import write_rgb8
    from blockhash.scene.loader import load_scene
    from blockhash.scene.preview import preview

    out = writable_path(Path(args.output or Path(args.scene).with_suffix(".preview.png").name), "--output")
    scene = load_scene(args.scene)
    colour, _ = preview(scene, size=args.size)
    h, w, _ = colour.shape
    write_rgb8(out, colour)
    print(f"preview of {args.scene}: {out} ({w} x {h}, pyrender)")
    return 0


def add_compare(sub) -> None:
    """Add ``compare`` to the subcommands ``sub``."""
    p = sub.add_parser("compare", help="per-layer RMS, relative RMS, max and FLIP error; limits "
                                       "set the exit status",
                       description="Compare image A with the reference B layer by layer: RMS, "
                                   "relative RMS (RMS(A - B) / RMS(B)), max error and mean FLIP "
                                   "(NVIDIA's perceptual difference of the tone-mapped layers). "
                                   "Exit status: 0 when every layer is within the limits given, "
                                   "1 when one is not (each failure is printed), 2 on bad input "
                                   "(missing file, different sizes or layers).",
                       epilog="Limits take one number for every layer or LAYER=NUMBER, repeated: "
                              "--max-rel-rms 0.1 --max-rel-rms direct=1e-4.")
    p.add_argument("a")
    p.add_argument("b", help="the reference")
    for option, what in (("--max-rms", "RMS(A - B)"), ("--max-rel-rms", "RMS(A - B) / RMS(B)"),
                         ("--max-flip", "mean FLIP (0..1)")):
        p.add_argument(option, type=_limit, action="append", metavar="[LAYER=]LIMIT",
                       help=f"largest {what} that passes")
    p.add_argument("--mask", metavar="LAYER_OR_IMAGE",
                   help="compare only where this layer of A, or this image, is non-zero; against a "
                        "light-traced or Mitsuba reference give the light tracer's comparison "
                        "mask: its pixels see a diffuse surface first, and pixels seen through "
                        "a mirror or glass are left out, because a reference that connects "
                        "caustics to the pinhole by a shadow ray cannot render them there "
                        "(their caustic is 0; check them with tools/mirror_identity.py)")
    p.add_argument("--json", metavar="PATH",
                   help="write the metrics, limits and failures as JSON to PATH ('-': stdout, "
                        "and the table goes to stderr); infinite values are the string \"inf\"")
    p.add_argument("--heatmap", metavar="PNG", help="write a false-colour error map per layer, "
                                                    "with a colour bar")
    p.add_argument("--strip", metavar="PNG", help="write A | B | error side by side, a row per layer")
    p.add_argument("--error", choices=("flip", "abs"), default="flip",
                   help="what --heatmap and --strip show: FLIP per pixel (default) or the "
                        "largest absolute channel error")
    p.add_argument("--vmax", type=float, help="top of the colour bars (default: 1 for FLIP, each "
                                              "layer's 99th percentile for abs)")
    p.add_argument("--diff", help="write |A - B| per layer to this EXR")
    p.set_defaults(func=cmd_compare)


def add_tolerance(sub) -> None:
    """Add ``tolerance`` to the subcommands ``sub``."""
    p = sub.add_parser("tolerance", help="propose compare limits from the noise between photon seeds",
                       description="Render a scene with several photon seeds at a small size, "
                                   "compare every pair of seeds (RMS, relative RMS, FLIP), measure "
                                   "the per-pixel spread, and propose limits for blockhash compare "
                                   "and assert_images_close: the largest pair value times --margin.")
    p.add_argument("scene", help="scene file (TOML), e.g. scenes/ring.toml")
    p.add_argument("--seeds", type=int, default=4, help="number of photon seeds (default 4)")
    p.add_argument("--first-seed", type=int, default=0, help="seeds are FIRST, FIRST+1, ... (default 0)")
    p.add_argument("--photons", type=int, help="caustic photons to store (default: the scene's)")
    p.add_argument("--size", type=size, default=(64, 64), help="image size (default 64x64)")
    p.add_argument("--k", type=int, help="photons per estimate (default: the scene's)")
    p.add_argument("--A", type=int, help="accuracy multiplier (default: the scene's)")
    p.add_argument("--method", choices=METHODS, default="bh")
    p.add_argument("--spp", type=int, help="samples per pixel (default: the scene's, else the "
                   "renderer's)")
    p.add_argument("--margin", type=float, default=1.5,
                   help="proposed limit = largest seed-pair value x MARGIN (default 1.5)")
    p.add_argument("--json", metavar="PATH", help="write the report as JSON to PATH ('-': stdout)")
    p.add_argument("--heatmap", metavar="PNG", help="write the per-pixel spread maps")
    p.add_argument("--backend", choices=BACKENDS, default=None)
    p.set_defaults(func=cmd_tolerance)


def add_info(sub) -> None:
    """Add ``info`` to the subcommands ``sub``."""
    p = sub.add_parser("info", help="OpenGL renderer, version, backend and limits",
                       description="Create the offscreen OpenGL context and print what it offers.")
    p.add_argument("--backend", choices=BACKENDS, default=None,
                   help="GL backend (default: $BLOCKHASH_GL or auto: EGL, then OSMesa)")
    p.set_defaults(func=cmd_info)


def add_preview(sub) -> None:
    """Add ``preview`` to the subcommands ``sub``."""
    p = sub.add_parser("preview", help="a quick pyrender view of a scene (camera, objects, lights)",
                       description="Render the scene with pyrender in a separate process, to check "
                                   "the camera, objects and lights before a real render.")
    p.add_argument("scene")
    p.add_argument("-o", "--output", help="PNG path (default: SCENE-NAME.preview.png here)")
    p.add_argument("--size", type=size, help=size_help())
    p.set_defaults(func=cmd_preview)
