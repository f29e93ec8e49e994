"""The mirror scene beside Mitsuba 3: the caustic seen in a mirror, which only the photon map
renders.

Renders ``scenes/mirror.toml`` (Lambertian floor, so the export drops nothing) with blockhash
(``blockhash.render``, the CLI's default 4 passes), and exports it to Mitsuba 3 and renders it
with ``ptracer`` (its whole image, and its caustic layer: ``blockhash reference --engine
mitsuba``'s isolation) and ``path``.  Reports the caustic flux (the sum of the caustic layer,
watts-free units of radiance times pixels) inside the mirror's pixels (the pixels whose camera
ray meets the wall first) and on the floor seen directly, for each: a particle tracer cannot
connect a caustic to the pinhole through a mirror, and a path tracer never reaches a point
light by sampling a BSDF, so Mitsuba's is 0 in the mirror (for ``path``, its image less
blockhash's direct layer: what it holds beyond direct light, which is also the light the
floor sends to the floor over the wall, L D S D E, small and alike everywhere).  The caustic's
pixels are those where blockhash's caustic is above 20% of its peak, in the mirror and on the
floor seen directly; blockhash's there is checked
against the mirror identity (rho times the same floor seen directly, over the pixels where
both views see the same point: ``tools/mirror_identity.py``).  Writes the three images with
one exposure (``--png-dir``).

usage: python tools/mitsuba_mirror.py [--size 256] [--spp 256] [--photons 200000]
                                      [--passes 4] [--png-dir docs] [--json FILE]
"""

import sys
from pathlib import Path

import numpy as np

import blockhash
from blockhash.evaluate.images import srgb, white_point, write_rgb8
from blockhash.evaluate.specular_identity import compare_views, specular_view_map
from blockhash.frame.scene_rays import SceneRays
from blockhash.passes.plan import RenderPlan
from blockhash.reference.mitsuba import mitsuba_reference, render_mitsuba
from blockhash.scene.camera import Pinhole
from blockhash.studies.command import ToolParser, count, timed, write_json


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("scenes/mirror.toml", many=False)
    p.add_argument("--wall", default="wall", help="the mirror's object name (default wall)")
    p.size(256)
    p.add_argument("--spp", type=count, default=256, help="Mitsuba's samples per pixel")
    p.photons(200_000, help="photons per pass")
    p.add_argument("--passes", type=count, default=4, help="blockhash's passes (default 4)")
    p.add_argument("--png-dir", type=Path, help="write the three images here")
    p.json_output()
    args = p.parse_args(argv)
    shown = args.scene.relative_to(p.root) if args.scene.is_relative_to(p.root) else args.scene
    size = (args.size, args.size)
    scene = blockhash.load_scene(args.scene).with_size(*size)
    pin = Pinhole.of(scene.camera)
    d = pin.pixel_rays()
    hit, _, _, obj, _ = SceneRays(scene.objects).first_hit(np.broadcast_to(pin.eye, d.shape).copy(), d)
    names = [o.name for o in scene.objects]
    wall = (obj == names.index(args.wall)).reshape(size[1], size[0])
    floor = np.zeros_like(wall)
    for i, o in enumerate(scene.objects):
        if not o.is_specular:
            floor |= (obj == i).reshape(size[1], size[0])
    bh, bh_s = timed(blockhash.render, scene, photons=args.photons,
                     plan=RenderPlan(passes=args.passes))
    ptracer, pt_s = render_mitsuba(scene, "ptracer", args.spp)
    path, path_s = render_mitsuba(scene, "path", args.spp)
    ref = mitsuba_reference(scene, args.spp, layers=("caustic",))
    lum = bh.caustic.sum(axis=2)
    wall_c = wall & (lum > 0.2 * lum[wall].max())     # the caustic's pixels in the mirror
    floor_c = floor & (lum > 0.2 * lum[floor].max())  # and on the floor seen directly
    view = specular_view_map(scene, through=[args.wall])
    ident = compare_views(view, bh.caustic)
    rows = {
        "blockhash caustic layer": (bh.caustic, bh_s),
        "Mitsuba ptracer caustic (isolated)": (ref.caustic, sum(ref.timings.values())),
        "Mitsuba path less blockhash's direct layer": (path - bh.direct, path_s),
    }
    out = {"scene": str(shown), "size": args.size, "spp": args.spp, "photons": args.photons,
           "passes": args.passes, "wall_pixels": int(wall.sum()),
           "caustic_pixels": {"mirror": int(wall_c.sum()), "floor": int(floor_c.sum())}, "rows": [],
           "identity": ident, "ptracer_seconds": pt_s}
    print(f"{shown}, {args.size} x {args.size}: {int(wall.sum()):,} mirror pixels; Mitsuba "
          f"{args.spp} spp; blockhash {args.photons:,} photons x {args.passes} passes\n")
    print(f"| renderer | caustic flux in the mirror ({int(wall_c.sum())} px; r, g, b) | on the floor "
          f"seen directly ({int(floor_c.sum())} px) | seconds |\n| --- | --- | --- | --- |")
    for name, (img, sec) in rows.items():
        img = np.asarray(img, dtype=np.float64)
        in_wall, on_floor = img[wall_c].sum(axis=0), img[floor_c].sum(axis=0)
        out["rows"].append({"renderer": name, "mirror": in_wall.tolist(), "floor": on_floor.tolist(),
                            "seconds": sec})
        print(f"| {name} | {', '.join(f'{v:.3f}' for v in in_wall)} | "
              f"{', '.join(f'{v:.3f}' for v in on_floor)} | {sec:.2f} |")
    print(f"\nblockhash's caustic in the mirror against rho times the floor seen directly, over the "
          f"{ident['pixels']:,} pixels where both views see the same point: flux ratio "
          f"{', '.join(f'{r:.4f}' for r in ident['ratio'])}, blurred relative RMS {ident['rel_rms']:.4f}")
    if args.png_dir:
        white = white_point(bh.combined)
        folder = args.png_dir
        folder.mkdir(parents=True, exist_ok=True)
        for name, img in (("mirror", bh.combined), ("mirror-mitsuba-ptracer", ptracer),
                          ("mirror-mitsuba-path", path)):
            write_rgb8(folder / f"{name}.png", np.round(srgb(img, white=white) * 255).astype(np.uint8))
        print(f"images: {folder}/mirror.png, mirror-mitsuba-ptracer.png, mirror-mitsuba-path.png "
              "(one exposure)")
    if args.json:
        write_json(args.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
