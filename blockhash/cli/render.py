"""``blockhash render``: render a scene's direct light and caustics in passes to a multi-layer
EXR and a PNG, until ``--passes``, ``--time`` or ``--target-error`` says stop (a progress bar on
a terminal, ``--preview-every`` rewriting the PNG, Ctrl-C writing the image so far);
``--time-budget`` and ``--study-error`` choose the photons, k and A of a one-pass render from
the scene's trade study.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

from blockhash.cli.args import FLAGS, INTERRUPTED, define_option, defines, size_help
from blockhash.cli.args import size as _size
from blockhash.cli.estimate import add_arguments as add_estimate_arguments
from blockhash.cli.estimate import options_from
from blockhash.device.choice import DEVICES
from blockhash.errors import InputError, NonFiniteError
from blockhash.frame.options import METHODS
from blockhash.gl.context import BACKENDS
from blockhash.scene.camera import DEFAULT_SPP
from blockhash.validate import writable_path

#: Exit status after Ctrl-C (128 + SIGINT), the image so far written.


def cmd_render(args) -> int:
    from blockhash.frame.options import LookupOptions
    from blockhash.passes.executors import PassFailed, WorkersFailed
    from blockhash.passes.pipeline import make_renderer
    from blockhash.passes.plan import TargetOutOfReach
    from blockhash.passes.run import run_passes
    from blockhash.scene.loader import load_scene

    out = Path(args.output or Path(args.scene).with_suffix(".exr").name)
    if out.suffix.lower() != ".exr":
        raise InputError(f"--output {out}: expected a .exr file name (the PNG preview is written "
                         "beside it)")
    writable_path(out, "--output")
    if args.preview_every is not None and not args.preview_every > 0:
        raise InputError(f"--preview-every {args.preview_every}: the PNG is rewritten every SECONDS "
                         "> 0; give e.g. --preview-every 5, or leave it out")
    scene = load_scene(args.scene, defines(args.define))
    if args.size:
        scene = scene.with_size(*args.size)
    if args.frames is not None:
        from blockhash.cli.frames import render_animation

        return render_animation(args, scene, out, _plan(args, one_pass=False))
    study = args.time_budget is not None or args.study_error is not None
    if study:
        _choose_settings(args, scene)
    plan = _plan(args, one_pass=study)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer, plan = make_renderer(
            scene, photons=args.photons, spp=args.spp, seed=args.seed,
            estimate=options_from(args), backend=args.backend, plan=plan,
            lookup=LookupOptions(method=args.method, k=args.k, A=args.A, variant=args.variant))
        progress = _Progress(renderer, plan, out, args.preview_every)
        try:
            run_passes(renderer, plan, on_pass=progress.update, on_wait=progress.waiting)
        except KeyboardInterrupt:
            progress.close()
            return _stop_early(renderer, out, "interrupted (Ctrl-C)", INTERRUPTED)
        except (TargetOutOfReach, PassFailed, WorkersFailed, NonFiniteError) as exc:
            progress.close()
            return _stop_early(renderer, out, f"error: {exc.spelled(FLAGS)}", 2)
        progress.close()
    for w in caught:
        print(f"WARNING: {w.message}", file=sys.stderr)
    result = _write(renderer, out)
    info = result.info
    print(f"scene: {args.scene} -> {out} (+ {out.with_suffix('.png').name})")
    print(f"passes: {result.passes} ({info.get('stopped_by')}) {info.get('executor')}; photons stored: "
          f"{info['photons_stored']:,} of {info['photons_emitted']:,} emitted")
    err = info["estimated_error"]
    print(f"density estimate: {info.get('estimate')}; {result.spp} samples per pixel; caustic "
          f"relative standard error {'n/a (one pass)' if err == float('inf') else f'{err:.3g}'}")
    if "index" in info:
        print(info["index"])
    if "indirect" in info:
        print(f"indirect light: {info['indirect']}")
    if "device" in info:
        print(f"caustic photons traced on: {info['device']}")
    print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items()))
    return 0


def _plan(args, *, one_pass: bool):
    """The :class:`RenderPlan` of ``--passes``, ``--time``, ``--target-error``, ``--alpha``,
    ``--footprint``, ``--workers`` and ``--scheduler``: without ``--passes``, a time or target runs passes until it holds, and
    neither the default rule (a trade-study setting: one pass)."""
    from blockhash.passes.plan import DEFAULT_PASSES, RenderPlan
    from blockhash.passes.schedule import Schedule

    if args.passes is not None:
        count = args.passes
    elif args.time is not None or args.target_error is not None:
        count = None
    else:
        count = 1 if one_pass else DEFAULT_PASSES
    schedule = Schedule(alpha=args.alpha, footprint=args.footprint)
    return RenderPlan(passes=count, seconds=args.time, target_error=args.target_error,
                      schedule=schedule, executor=_executor(args), indirect=not args.no_indirect,
                      device=args.device)


def _executor(args):
    """Where the passes run: ``--workers N`` local processes, ``--scheduler ADDRESS`` a Dask
    cluster, else this process."""
    from blockhash.passes.executors import InProcess, LocalWorkers, worker_count

    if args.workers is not None and args.scheduler is not None:
        raise InputError(f"--workers {args.workers} and --scheduler {args.scheduler}: passes run "
                         "either in local worker processes or on a Dask cluster; give one")
    if args.scheduler is not None:
        from blockhash.passes.dask_cluster import DaskCluster

        return DaskCluster(args.scheduler)
    if args.workers is not None:
        return LocalWorkers(worker_count(args.workers))
    return InProcess()


def _write(renderer, out: Path, **attributes):
    from blockhash.evaluate.images import write_exr, write_png

    result = renderer.image
    info = result.info
    write_exr(out, result.layers(), {
        "blockhash:spp": result.spp, "blockhash:passes": result.passes,
        "blockhash:photons_emitted": int(info["photons_emitted"]),
        "blockhash:estimated_error": float(info["estimated_error"]), **attributes})
    write_png(out.with_suffix(".png"), result.combined)
    return result


def _stop_early(renderer, out: Path, why: str, code: int) -> int:
    """Write the image of the passes done (nothing to write before the first) and say so."""
    if renderer.passes == 0:
        print(f"blockhash render: {why} before the first pass ended; nothing written",
              file=sys.stderr)
        return code
    _write(renderer, out, **{"blockhash:stopped": why})
    print(f"blockhash render: {why}; wrote the image of {renderer.passes} "
          f"pass{'es' if renderer.passes > 1 else ''} to {out} (+ {out.with_suffix('.png').name}; "
          "its pass count in the EXR's blockhash:passes)", file=sys.stderr)
    return code


class _Progress:
    """The progress bar (on a terminal: passes done and in flight, workers, photons, elapsed
    time, estimated error) and the PNG rewritten every ``preview_every`` seconds."""

    def __init__(self, renderer, plan, out: Path, preview_every):
        self.out, self.preview_every = out, preview_every
        self.last_preview = time.perf_counter()
        self.bar = None
        if sys.stderr.isatty():
            from tqdm.auto import tqdm

            self.bar = tqdm(total=plan.passes, unit="pass", desc="render", file=sys.stderr)

    def update(self, renderer, stats, elapsed: float, session) -> None:
        if self.bar is not None:
            err = renderer.film.estimated_error()
            self.bar.set_postfix_str(
                f"in flight {session.in_flight}, workers {session.workers}, photons "
                f"{renderer.stored:,}, error {'-' if err == float('inf') else f'{err:.3g}'}")
            self.bar.update(1)
        now = time.perf_counter()
        if self.preview_every is not None and now - self.last_preview >= self.preview_every:
            from blockhash.evaluate.images import write_png

            write_png(self.out.with_suffix(".png"), renderer.image.combined)
            self.last_preview = now

    def waiting(self, session) -> None:
        if self.bar is not None:
            self.bar.set_description_str(f"render ({session.in_flight} in flight)")

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _choose_settings(args, scene) -> None:
    """Fill args.photons, k, A from the scene's trade study for --time-budget / --target-error."""
    if not scene.specular_objects:
        print("settings: the scene has no specular object, so no caustic photons are traced and "
              "no index is built; the budget applies to nothing")
        return
    from blockhash.studies.tradeoff.budget import choose, study_for

    if args.photons is not None or args.k is not None or args.A is not None:
        raise InputError("--time-budget / --study-error choose --photons, --k and --A; give "
                         "either those or a budget, not both")
    cache = Path(args.cache) if args.cache else Path.home() / ".cache" / "blockhash"
    study = study_for(scene, cache_dir=cache, study_path=args.tradeoff, backend=args.backend,
                      progress=lambda s: print(s, file=sys.stderr))
    choice = choose(study, pixels=scene.camera.width * scene.camera.height,
                    time_budget=args.time_budget, target_error=args.study_error)
    args.photons, args.k, args.A = choice.photons, choice.k, choice.A
    print(f"settings: photons {choice.photons:,}, k {choice.k}, A {choice.A}: {choice.reason}; "
          f"predicted {choice.predicted_seconds:.2f} s for trace + index + caustic pass, relative "
          f"RMS {choice.predicted_error:.3f} against the reference (2 px blur, at the study's "
          f"{study['size'][0]} x {study['size'][1]})")


def add_render(sub) -> None:
    """Add ``render`` to the subcommands ``sub``."""
    from blockhash.passes.plan import DEFAULT_PASSES
    from blockhash.passes.schedule import DEFAULT_ALPHA, DEFAULT_FOOTPRINT

    p = sub.add_parser("render", help="render a scene's direct light and caustics to EXR and PNG",
                       description="Render in passes (progressive photon mapping): each pass "
                                   "traces a fresh batch of caustic photons, indexes them, takes "
                                   "a fresh camera sample per pixel with its direct light and "
                                   "caustic estimate, and shrinks the photons' radii; the image "
                                   "is the running mean.  Writes a multi-layer EXR (direct, "
                                   "caustic, combined) and a tone-mapped PNG.  Ctrl-C writes the "
                                   "image so far and exits with status 130.")
    p.add_argument("scene", help="scene file (TOML, or Mitsuba 3 XML), e.g. scenes/ring.toml")
    define_option(p)
    p.add_argument("-o", "--output", help="EXR path (default: SCENE-NAME.exr here)")
    p.add_argument("--passes", type=int, metavar="N",
                   help=f"stop after N passes (default {DEFAULT_PASSES}, or no limit when --time "
                        "or --target-error is given)")
    p.add_argument("--time", type=float, metavar="SECONDS",
                   help="stop after the pass that ends past SECONDS")
    p.add_argument("--target-error", type=float, metavar="E",
                   help="stop once the caustic layer's estimated relative standard error (from "
                        "the spread between passes) is <= E")
    p.add_argument("--alpha", type=float, default=DEFAULT_ALPHA,
                   help="share of a pass's photons kept in the next radius, in (0, 1) (Knaus "
                        f"and Zwicker; default {DEFAULT_ALPHA:.3g})")
    p.add_argument("--footprint", type=float, default=DEFAULT_FOOTPRINT,
                   help="splat into their pixel the photons whose discs are under this many "
                        "pixel footprints (blockhash/passes/schedule.py; default "
                        f"{DEFAULT_FOOTPRINT:g}; 0: off)")
    p.add_argument("--preview-every", type=float, metavar="SECONDS",
                   help="rewrite the PNG every SECONDS as the image refines")
    p.add_argument("--photons", type=int, help="caustic photons to store per pass (default: the "
                   "scene's)")
    p.add_argument("--frames", nargs="?", const="", metavar="A:B",
                   help="render the frames of the scene's [animation] (all, or frames A .. B-1, "
                        "or one frame N): OUTPUT-0000.exr and .png per frame and OUTPUT.mp4; "
                        "each frame is a render of --passes passes; Ctrl-C keeps the frames done")
    p.add_argument("--no-indirect", action="store_true",
                   help="leave out the light between diffuse surfaces (the indirect layer, "
                        "photons after a diffuse bounce; the EXR then has no indirect layer), "
                        "for caustic-only studies")
    p.add_argument("--k", type=int, help="photons per estimate (default: the scene's)")
    p.add_argument("--A", type=int, help="accuracy multiplier (default: the scene's)")
    p.add_argument("--method", choices=METHODS, default="auto",
                   help="auto (default): cover for the conserving estimate, else bh; cover: every "
                        "photon whose own disc covers the point (shader); bh: the k nearest by "
                        "Block Hashing (shader); kdtree: exact kNN (kd-tree shader); cpu: the CPU "
                        "reference of what auto picks")
    p.add_argument("--variant", default="default", help="BH shader variant")
    p.add_argument("--size", type=_size, help=size_help())
    p.add_argument("--spp", type=int, help="samples per pixel per pass, a square number "
                   "(stratified jitter, box filter; default: the scene's [camera] spp, else "
                   f"{DEFAULT_SPP} with --passes 1 and 1 per pass in more)")
    p.add_argument("--seed", type=int, help="photon seed (default: the scene's)")
    p.add_argument("--backend", choices=BACKENDS, default=None)
    p.add_argument("--device", choices=DEVICES, default=None,
                   help="where the caustic photons are traced: auto (the GPU where there is one, "
                        "else the CPU's Dr.Jit kernels, else the host tracer), cpu, gpu or host "
                        "(default: $BLOCKHASH_DEVICE, else auto)")
    p.add_argument("--workers", metavar="N",
                   help="run the passes in N local worker processes ('auto': one per core); the "
                        "image is the same as in one process")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run the passes on an existing Dask cluster (dask scheduler / dask worker; "
                        "pip install 'blockhash[distributed]'); the image is the same")
    p.add_argument("--time-budget", type=float, metavar="SECONDS",
                   help="choose photons, k and A of a one-pass render from the scene's trade "
                        "study: least error that fits")
    p.add_argument("--study-error", type=float, metavar="E",
                   help="choose the fastest one-pass setting of the scene's trade study whose "
                        "relative RMS against the reference is <= E")
    p.add_argument("--tradeoff", help="tradeoff.json to choose from (default: the cached study of "
                   "this scene, else a short calibration run)")
    p.add_argument("--cache", help="cache directory (default ~/.cache/blockhash)")
    add_estimate_arguments(p)
    p.set_defaults(func=cmd_render)
