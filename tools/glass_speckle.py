"""The glass ball's speckle: the direct layer at the default samples per pixel against the same
render at many, inside the ball's silhouette (and one pixel in from its edge) and on the floor.

With ``--mitsuba-spp N``, also the ball's pixels against Mitsuba 3's path tracer (the extra
blockhash[mitsuba]) on the scene with ks = 0: blockhash's direct layer (what the camera sees
through and in the ball, lit directly) against Mitsuba's ``path`` image (the same light: a
path tracer cannot reach a point light over glass, so it holds no caustic), blurred relative
RMS inside the silhouette.

usage: python tools/glass_speckle.py [--size 128] [--spp-ref 256] [--photons 50000]
                                     [--mitsuba-spp 1024]
"""

import argparse
import sys

import numpy as np
from scipy.ndimage import binary_erosion

from blockhash.frame.gbuffer import rasterize
from blockhash.frame.pipeline import render_scene
from blockhash.scene.loader import load_scene


def rel(a, b, mask) -> float:
    d = a[mask] - b[mask]
    return float(np.sqrt((d ** 2).mean()) / b[mask].mean())


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="scenes/glass.toml")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--spp-ref", type=int, default=256)
    p.add_argument("--photons", type=int, default=50_000)
    p.add_argument("--mitsuba-spp", type=int, help="also compare with Mitsuba's path tracer")
    args = p.parse_args(argv)
    scene = load_scene(args.scene)
    size = (args.size, args.size)
    few = render_scene(scene, size=size, photons=args.photons)
    many = render_scene(scene, size=size, photons=args.photons, spp=args.spp_ref)
    obj = rasterize(scene.camera, scene.objects, size=size).object
    ball = obj == [i for i, o in enumerate(scene.objects) if o.is_dielectric][0]
    print(f"{args.size} x {args.size}, {few.spp} spp against {many.spp}: direct layer relative "
          f"RMS inside the ball's silhouette {rel(few.direct, many.direct, ball):.4f}, one pixel "
          f"in from its edge {rel(few.direct, many.direct, binary_erosion(ball)):.4f}, on the "
          f"floor seen directly {rel(few.direct, many.direct, obj == 0):.4f}")
    if args.mitsuba_spp:
        from blockhash.reference.mitsuba import mitsuba_reference, without_specular_lobes
        from blockhash.studies.measure import masked_blur, rel_rms

        plain = without_specular_lobes(scene).with_size(*size)
        ours = render_scene(plain, photons=args.photons).direct
        theirs = mitsuba_reference(plain, args.mitsuba_spp, layers=("direct",)).direct
        print(f"against Mitsuba's path tracer at {args.mitsuba_spp} spp (ks = 0): blurred relative "
              f"RMS inside the ball's silhouette "
              f"{rel_rms(masked_blur(ours, ball), masked_blur(theirs, ball), ball):.4f}, relative "
              f"RMS {rel_rms(ours, theirs, ball):.4f}, on the floor seen directly "
              f"{rel_rms(masked_blur(ours, obj == 0), masked_blur(theirs, obj == 0), obj == 0):.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
