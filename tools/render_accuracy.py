"""Caustic image error of Block Hashing against the exact k nearest photons, per A.

Renders a scene's caustic layer with the BH shader (``method="bh"``) at each A on one
photon map and compares it with the exact-kNN estimate (cKDTree) of the same map: relative
RMS (RMS(BH - exact) / RMS(exact)) and the mean brightness ratio (approximate
radii are larger, so BH images are darker, paper section 6).  Both images take one
shading point per pixel, the rasteriser's pixel centre.

    python tools/render_accuracy.py scenes/ring.toml --size 128x128 --photons 100000
"""

from __future__ import annotations

import numpy as np

from blockhash.frame.caustic import estimate_exact
from blockhash.frame.gbuffer import rasterize
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.passes.pipeline import render_scene
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.scene.loader import load_scene
from blockhash.scene.materials import receiver_materials
from blockhash.scene.model import MirrorMaterial
from blockhash.studies.command import ToolParser, count, listing


def main(argv=None) -> None:
    p = ToolParser(__doc__, __file__)
    p.add_argument("scene", type=p.scene, help="scene file or name under scenes/")
    p.size((128, 128), square=False, help="image size, 128x128 or 128")
    p.photons(100_000, help="photons stored")
    p.add_argument("--A", type=listing(count), default=[1, 2, 4, 8, 16],
                   help="Block Hashing's A (comma-separated; default 1,2,4,8,16)")
    p.add_argument("--seed", type=int, default=1)
    args = p.parse_args(argv)
    size = args.size
    scene = load_scene(args.scene)
    shown = args.scene.relative_to(p.root) if p.root in args.scene.parents else args.scene
    photons = trace_caustic_photons(scene, args.photons, seed=args.seed)
    g = rasterize(scene.camera, scene.objects, size=size)
    points = shading_points(scene.camera, g, scene.objects, SceneRays(scene.objects), (MirrorMaterial,))
    exact = None
    print(f"{shown}: {len(photons.positions):,} photons, {size[0]}x{size[1]}, "
          f"k={scene.photons.k}; exact = cKDTree k nearest on the same map")
    print(f"{'A':>3} {'relative RMS':>13} {'mean BH/exact':>14} {'caustic pass s':>15}")
    for A in args.A:
        # One sample per pixel, at the centres the exact estimate is taken at: the two
        # images then differ only in the neighbours each search found.
        r = render_scene(scene, photon_map=photons, A=A, size=size, spp=1, method="bh")
        if exact is None:
            exact = estimate_exact(r.index, points, receiver_materials(scene.objects), gpu=False)
        err = np.sqrt(np.mean((r.caustic - exact) ** 2)) / np.sqrt(np.mean(exact ** 2))
        print(f"{A:>3} {err:>13.4f} {r.caustic.mean() / exact.mean():>14.4f} "
              f"{r.timings['caustic']:>15.2f}", flush=True)


if __name__ == "__main__":
    main()
