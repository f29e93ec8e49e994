"""The glass ball's speckle: the direct layer at the default samples per pixel against the same
render at many, inside the ball's silhouette (and one pixel in from its edge) and on the floor.

With ``--mitsuba-spp N``, also the ball's pixels against Mitsuba 3's path tracer (the extra
blockhash[mitsuba]) on the scene with ks = 0: blockhash's direct layer (what the camera sees
through and in the ball, lit directly) against Mitsuba's ``path`` image (the same light: a
path tracer cannot reach a point light over glass, so it holds no caustic), blurred relative
RMS inside the silhouette.

With ``--one-branch``, also the same at the default spp with one random branch per camera
sample at glass (the renderer before it followed both), against the same reference.

usage: python tools/glass_speckle.py [--size 128] [--spp-ref 256] [--one-branch]
                                     [--mitsuba-spp 1024]
"""

import sys

import numpy as np
from scipy.ndimage import binary_erosion

from blockhash.frame.gbuffer import rasterize
from blockhash.passes.pipeline import direct_layer
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count


def rel(a, b, mask) -> float:
    d = a[mask] - b[mask]
    return float(np.sqrt((d ** 2).mean()) / b[mask].mean())


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("scenes/glass.toml", many=False)
    p.size(128)
    p.add_argument("--spp-ref", type=count, default=256)
    p.add_argument("--one-branch", action="store_true",
                   help="also one random branch per sample at glass")
    p.add_argument("--mitsuba-spp", type=count, help="also compare with Mitsuba's path tracer")
    args = p.parse_args(argv)
    scene = load_scene(args.scene)
    size = (args.size, args.size)
    many = direct_layer(scene, args.spp_ref, size=size)
    obj = rasterize(scene.camera, scene.objects, size=size).object
    ball = obj == [i for i, o in enumerate(scene.objects) if o.is_dielectric][0]
    for label, both in (("both branches", True), ("one branch", False))[:1 + args.one_branch]:
        few = direct_layer(scene, size=size, both_branches=both)
        print(f"{args.size} x {args.size}, the default spp against {args.spp_ref}, {label}: "
              f"direct layer relative RMS inside the ball's silhouette {rel(few, many, ball):.4f}, "
              f"one pixel in from its edge {rel(few, many, binary_erosion(ball)):.4f}, on the "
              f"floor seen directly {rel(few, many, obj == 0):.4f}")
    if args.mitsuba_spp:
        from blockhash.reference.mitsuba import mitsuba_reference, without_specular_lobes
        from blockhash.studies.measure import masked_blur, rel_rms

        plain = without_specular_lobes(scene).with_size(*size)
        ours = direct_layer(plain)
        theirs = mitsuba_reference(plain, args.mitsuba_spp, layers=("direct",)).direct
        print(f"against Mitsuba's path tracer at {args.mitsuba_spp} spp (ks = 0): blurred relative "
              f"RMS inside the ball's silhouette "
              f"{rel_rms(masked_blur(ours, ball), masked_blur(theirs, ball), ball):.4f}, relative "
              f"RMS {rel_rms(ours, theirs, ball):.4f}, on the floor seen directly "
              f"{rel_rms(masked_blur(ours, obj == 0), masked_blur(theirs, obj == 0), obj == 0):.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
