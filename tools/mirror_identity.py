"""The mirror identity: on a Lambertian receiver, the radiance a render shows in a perfect
planar mirror of reflectance rho is rho times the radiance of the same receiver point seen
directly (through a glass slab, (1 - F_in)(1 - F_out) times it, in the caustic layer).

Each pixel whose camera ray meets the named planar mirror (or glass) first is followed to its
receiver point, and that point projected to the pixel that sees it directly; pixels kept
where both views see the same unoccluded point.  Both views are blurred to the coarser of
their two pixel footprints, the direct view resampled at the receiver points, and compared:
flux ratio and blurred relative RMS, for the caustic layer over photon seeds and for the
direct layer over jitter seeds.  The limits: 3 standard deviations of one render's flux in
those pixels between seeds, and 2 times one render's own blurred RMS about the seeds' mean,
each plus the resampling's error (bilinear against nearest-pixel sampling of the direct view)
(blockhash/evaluate/specular_identity.py).  Exit status 1 when the identity does not hold.

usage: python tools/mirror_identity.py [SCENE] [--size 128] [--photons 50000] [--spp 4]
                                       [--seeds 1,2,3,4] [--through wall] [--json FILE]
"""

import sys

from blockhash.evaluate.specular_identity import identity_check
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count, listing, write_json


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.add_argument("scene", nargs="?", type=p.scene, default="scenes/mirror.toml",
                   help="a scene file or name under scenes/ (default scenes/mirror.toml)")
    p.size(128)
    p.photons(50_000)
    p.add_argument("--spp", type=count, default=4)
    p.add_argument("--seeds", type=listing(count), default=[1, 2, 3, 4])
    p.add_argument("--through", type=listing(str), default=None, help="comma-separated planar "
                   "mirror or glass objects (default: every planar mirror and flat-faced glass "
                   "object)")
    p.json_output()
    args = p.parse_args(argv)
    scene = load_scene(args.scene)
    shown = args.scene.relative_to(p.root) if args.scene.is_relative_to(p.root) else args.scene
    report = identity_check(scene, size=(args.size, args.size), photons=args.photons,
                            spp=args.spp, seeds=tuple(args.seeds), through=args.through or None)
    print(f"{shown}, {args.size} x {args.size}, {args.photons:,} photons, {args.spp} spp: "
          f"{report['pixels']:,} pixels seen through the specular surface and directly; "
          f"footprint {report['footprint']:.3f} direct pixels per specular pixel, box blur "
          f"{report['blur'][0]} (specular view) and {report['blur'][1]} (direct view)")
    print("| layer | flux ratio (r, g, b) per run | limit on abs(ratio - 1) | blurred rel. RMS per run "
          "| limit | holds |\n| --- | --- | --- | --- | --- | --- |")
    for name, layer in report["layers"].items():
        ratios = "; ".join(", ".join(f"{c:.4f}" for c in r["ratio"]) for r in layer["runs"])
        rms = ", ".join(f"{r['rel_rms']:.4f}" for r in layer["runs"])
        print(f"| {name} | {ratios} | {layer['limits']['ratio']:.4f} | {rms} | "
              f"{layer['limits']['rel_rms']:.4f} | {'yes' if layer['holds'] else 'NO'} |")
    if args.json:
        write_json(args.json, {"scene": str(shown), "size": args.size,
                               "photons": args.photons, "spp": args.spp, **report})
    return 0 if all(layer["holds"] for layer in report["layers"].values()) else 1


if __name__ == "__main__":
    sys.exit(main())
