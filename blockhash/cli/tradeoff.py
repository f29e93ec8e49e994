"""``blockhash tradeoff``: the trade study of speed against accuracy on the command line."""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from blockhash.cli.args import size as _size
from blockhash.cli.args import size_help
from blockhash.frame.options import METHODS
from blockhash.gl.context import BACKENDS

#: The methods the trade study sweeps as Block Hashing (``kdtree``'s exact kNN is measured beside
#: either), from the one list of methods, and the engine each runs the sweep on.
METHOD_ENGINE = {"bh": "gl", "cpu": "cpu"}
SWEPT_METHODS = tuple(m for m in METHODS if m in METHOD_ENGINE)
ENGINE_METHOD = {engine: method for method, engine in METHOD_ENGINE.items()}


class _OldEngine(argparse.Action):
    """``tradeoff --engine {gl,cpu}``, the older spelling of ``--method {bh,cpu}``: still
    taken, with a note naming the new form."""

    def __call__(self, parser, namespace, value, option_string=None):
        method = ENGINE_METHOD[value]
        print(f"blockhash: --engine {value} is now --method {method}; --engine goes in the next "
              "release", file=sys.stderr)
        setattr(namespace, self.dest, method)


def _int_list(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(float(v)) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected comma-separated integers such as "
                                         "1000,10000,100000") from None


def cmd_tradeoff(args) -> int:
    from blockhash.reference.lighttrace import lambertian
    from blockhash.scene.loader import load_scene
    from blockhash.studies.tradeoff.budget import remember
    from blockhash.studies.tradeoff.report import write_study
    from blockhash.studies.tradeoff.sweep import QUICK, SweepPlan, run_sweep, with_plan

    if args.replot:
        from blockhash.studies.tradeoff.report import rewrite_report

        print(f"report: {rewrite_report(args.output)}")
        return 0
    scene = load_scene(args.scene)
    if args.lambertian:
        scene = lambertian(scene)
    plan = with_plan(QUICK if args.quick else SweepPlan(), photons=args.photons, size=args.size,
                     grid_A=args.A, ks=args.ks,
                     engine=METHOD_ENGINE[args.method] if args.method else None,
                     reference_photons=args.reference_photons)
    cache = Path(args.cache) if args.cache else Path.home() / ".cache" / "blockhash"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # orphan warnings of small or 'paper' indexes: in the rows
        study = run_sweep(scene, plan, cache_dir=cache, backend=args.backend,
                          progress=lambda s: print(s, file=sys.stderr))
    study["command"] = "blockhash " + " ".join(sys.argv[1:]) if sys.argv[1:2] == ["tradeoff"] \
        else f"blockhash tradeoff {args.scene} -o {args.output}" + (" --quick" if args.quick else "")
    study["lambertian"] = bool(args.lambertian)
    remember(study, scene, cache)
    path = write_study(study, args.output)
    bh = [r for r in study["rows"] if r["method"] == "bh"]
    best = min(bh, key=lambda r: r["rel_rms_reference_blur"])
    print(f"{len(study['rows'])} settings of {args.scene} in {study['seconds_total']:.0f} s -> {path}")
    print(f"least error against the reference: N={best['photons']:,} k={best['k']} A={best['A']} "
          f"({best['preset']}/{best['variant']}): relative RMS {best['rel_rms_reference_blur']:.3f} "
          f"(2 px blur), flux ratio {best['flux_ratio_reference']:.3f}")
    print(f"report: {Path(args.output) / 'report.md'}")
    return 0


def add_tradeoff(sub) -> None:
    """Add ``tradeoff`` to the subcommands ``sub``."""
    p = sub.add_parser("tradeoff", help="measure speed against accuracy over N, k, A, presets, variants",
                       description="Sweep photon count, k, A, index preset and shader variant on a "
                                   "scene; time every stage and measure the caustic layer against "
                                   "exact kNN and an unbiased light-traced reference; write "
                                   "DIR/tradeoff.json, plots and DIR/report.md.")
    p.add_argument("scene", help="scene file (TOML) with at least one mirror")
    p.add_argument("-o", "--output", required=True, help="output directory")
    p.add_argument("--quick", action="store_true", help="a small sweep (about a minute here)")
    p.add_argument("--photons", type=_int_list, help="photon counts, e.g. 10000,100000,1000000")
    p.add_argument("--A", type=_int_list, help="A values of the grid, e.g. 1,2,4,8,16,32,64")
    p.add_argument("--k", "--ks", dest="ks", type=_int_list,
                   help="k values, e.g. 16,50,100 (--ks is the older name)")
    p.add_argument("--size", type=_size, help=size_help("128x128; quick 48x48"))
    p.add_argument("--method", choices=SWEPT_METHODS, default=None,
                   help="bh: the caustic pass shader (default); cpu: its CPU reference (no shader "
                   "compiles; CPU times); exact kNN is measured beside either")
    p.add_argument("--engine", choices=tuple(ENGINE_METHOD), action=_OldEngine, dest="method",
                   help=argparse.SUPPRESS)
    p.add_argument("--reference-photons", type=int, help="photons of the light-traced reference")
    p.add_argument("--lambertian", action="store_true", help="set every Phong material's ks to 0")
    p.add_argument("--replot", action="store_true",
                   help="only redraw the plots and report.md of DIR from its tradeoff.json")
    p.add_argument("--cache", help="cache directory of references (default ~/.cache/blockhash)")
    p.add_argument("--backend", choices=BACKENDS, default=None)
    p.set_defaults(func=cmd_tradeoff)
