"""``blockhash export`` and ``blockhash reference``: the scene in Mitsuba 3, and a reference
image from blockhash's light tracer or from Mitsuba.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from blockhash.cli.args import define_option, defines, size, size_help
from blockhash.errors import InputError
from blockhash.validate import writable_path


def cmd_export(args) -> int:
    from blockhash.scene.loader import load_scene
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise InputError(f"-o {out}: is a file; give a folder to write scene.xml and meshes/ into")
    xml = export_mitsuba(load_scene(args.scene), out, drop_specular=args.drop_specular,
                         spp=args.spp)
    print(f"exported {args.scene} -> {xml} (+ {len(list((out / 'meshes').glob('*.ply')))} PLY "
          f"meshes in {out / 'meshes'}); render it with: mitsuba -D spp=256 {xml}")
    return 0


def blockhash_reference(scene, spp: int, photons: int, *, seed: int = 0):
    """(layers, timings) of blockhash's own reference: the light tracer's caustic layer
    (:mod:`blockhash.reference.lighttrace`, ``photons`` shot) and the direct layer at ``spp``
    stratified samples per pixel."""
    import time

    from blockhash.passes.pipeline import direct_layer
    from blockhash.reference.lighttrace import light_trace

    timings = {}
    t = time.perf_counter()
    direct = direct_layer(scene, spp, seed=seed)
    timings["direct"] = time.perf_counter() - t
    t = time.perf_counter()
    caustic = light_trace(scene, photons, seed=None).radiance.astype(np.float32)
    timings["caustic (light tracer)"] = time.perf_counter() - t
    return {"direct": direct, "caustic": caustic, "combined": direct + caustic}, timings


def cmd_reference(args) -> int:
    from blockhash.evaluate.images import write_exr, write_png
    from blockhash.scene.loader import load_scene

    out = Path(args.output or Path(args.scene).with_suffix(".reference.exr").name)
    if out.suffix.lower() != ".exr":
        raise InputError(f"--output {out}: expected a .exr file name")
    writable_path(out, "--output")
    scene = load_scene(args.scene, defines(args.define))
    if args.size:
        scene = scene.with_size(*args.size)
    if args.engine == "mitsuba":
        from blockhash.reference.mitsuba import mitsuba_reference, without_specular_lobes

        ref = mitsuba_reference(scene, args.spp, seed=args.seed)
        layers, timings = ref.layers(), ref.timings
        attrs = {"blockhash:engine": f"mitsuba {ref.variant}", "blockhash:spp": args.spp}
        scene = without_specular_lobes(scene)
    else:
        layers, timings = blockhash_reference(scene, args.spp, args.photons, seed=args.seed)
        attrs = {"blockhash:engine": "blockhash light tracer", "blockhash:spp": args.spp,
                 "blockhash:photons": args.photons}
    write_exr(out, layers, attrs)
    write_png(out.with_suffix(".png"), layers["combined"])
    print(f"reference of {args.scene} ({args.engine}) -> {out} (+ {out.with_suffix('.png').name})")
    if args.engine == "mitsuba":
        print("note: Mitsuba has no modified Phong; the scene's ks lobes are dropped, so compare "
              "with a blockhash render of the scene with ks = 0")
    print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in timings.items()))
    return 0


def add_export(sub) -> None:
    """Add ``export`` to the subcommands ``sub``."""
    p = sub.add_parser("export", help="write a scene as a Mitsuba 3 XML file with PLY meshes",
                       description="Write SCENE as DIR/scene.xml (Mitsuba 3) and DIR/meshes/*.ply. "
                                   "Mitsuba has no modified Phong: a material with ks > 0 is an "
                                   "error unless --drop-specular.")
    p.add_argument("scene", help="scene file (TOML or Mitsuba XML)")
    p.add_argument("--to", choices=("mitsuba",), default="mitsuba", help="the format (mitsuba)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="folder to write into")
    p.add_argument("--drop-specular", action="store_true",
                   help="write modified Phong materials with ks > 0 as diffuse (kd only), with "
                        "a comment in the XML")
    p.add_argument("--spp", type=int, default=64,
                   help="the XML's default sample count (Mitsuba's -D spp=N overrides it)")
    p.set_defaults(func=cmd_export)


def add_reference(sub) -> None:
    """Add ``reference`` to the subcommands ``sub``."""
    p = sub.add_parser("reference", help="a reference image: blockhash's light tracer, or Mitsuba 3",
                       description="Render the reference of SCENE's layers (direct, caustic, "
                                   "combined) to a multi-layer EXR that `blockhash compare` "
                                   "takes. --engine mitsuba needs the extra blockhash[mitsuba].")
    p.add_argument("scene")
    define_option(p)
    p.add_argument("-o", "--output", help="EXR path (default: SCENE-NAME.reference.exr here)")
    p.add_argument("--engine", choices=("blockhash", "mitsuba"), default="blockhash")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    p.add_argument("--photons", type=int, default=10_000_000,
                   help="photons the light tracer shoots (--engine blockhash; default 10^7)")
    p.add_argument("--size", type=size, help=size_help())
    p.add_argument("--seed", type=int, default=0)
    p.set_defaults(func=cmd_reference)
