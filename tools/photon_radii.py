"""The conserving estimate's photon radii from the map's own index against exact ones.

For each scene (Lambertian receivers), one photon map of ``--photons``: both sets of radii
are computed and timed beside the index build (``photon_radius.own_radii2``, the index's
own query, and ``exact_radii2``, scipy's cKDTree), their squared-radius ratio summed up,
and the caustic pass rendered with each on the scene's own shading points (``--spp``
samples per pixel); each image is compared with the light tracer's reference (caustic flux
and blurred relative RMS over the caustic region, as ``tools/spp_sweep.py``) and with the
other (relative RMS).

    python tools/photon_radii.py scenes/ring.toml scenes/venus.toml --photons 1e6 --spp 1

``--size`` renders (and traces the reference) at another square size than the scene's.
``--times-only`` skips the reference and the images: the index build as the render makes it
(records in Hilbert order, no hash tables) and in full, then both radii, each ``--repeat``
times in turn (medians).
"""

from __future__ import annotations

import sys

import numpy as np

from blockhash import BlockHashIndex
from blockhash.frame.caustic import CausticPass
from blockhash.frame.photon_radius import exact_radii2, own_radii2
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.frame.subpixel import box_filter, raycast_gbuffer
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.scene.camera import SPP_SEED, spp_grid
from blockhash.scene.loader import load_scene
from blockhash.scene.materials import receiver_materials
from blockhash.scene.model import MirrorMaterial
from blockhash.studies.command import ToolParser, count, side, timed
from blockhash.studies.density.estimates import lambertian_reference, measure, reference_options
from blockhash.studies.measure import rel_rms


def index_of(scene, pm, **kwargs) -> BlockHashIndex:
    """The photon map's index with the scene's k and A."""
    return BlockHashIndex(pm.positions, k=scene.photons.k, A=scene.photons.A,
                          directions=pm.directions, normals=pm.normals, powers=pm.powers, **kwargs)


def times_only(paths, photons: int, repeat: int) -> int:
    """Median seconds of the index builds and the radii, side by side in one run (each repeat
    builds its own index, so no radii are cached from one repeat to the next)."""
    for path in paths:
        scene = load_scene(path)
        pm = trace_caustic_photons(scene, photons, seed=scene.photons.seed)
        k = scene.photons.k
        times = {"index (render: no tables)": [], "index (full)": [], "own radii": [],
                 "exact radii (cKDTree)": []}
        for _ in range(repeat):
            for tables in (False, True):
                index, t = timed(index_of, scene, pm, tables=tables)
                times["index (full)" if tables else "index (render: no tables)"].append(t)
            for name, fn in (("own radii", own_radii2), ("exact radii (cKDTree)", exact_radii2)):
                times[name].append(timed(fn, index, k)[1])
        print(f"{path.stem}, {len(pm.positions):,} photons, median of {repeat}: "
              + "; ".join(f"{name} {np.median(v):.2f} s" for name, v in times.items()), flush=True)
    return 0


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.add_argument("scenes", nargs="+", type=p.scene, help="scene files or names under scenes/")
    p.photons(1_000_000, help="photons stored")
    p.add_argument("--spp", type=count, default=1, help="samples per pixel, a square number")
    reference_options(p, 100_000_000)
    p.add_argument("--size", type=side, default=None,
                   help="square image side, 128 or 128x128 (default the scene's)")
    p.add_argument("--times-only", action="store_true", help="time the builds and radii only")
    p.add_argument("--repeat", type=count, default=3, help="runs of each timing (--times-only)")
    a = p.parse_args(argv)
    if a.times_only:
        return times_only(a.scenes, a.photons, a.repeat)
    grid = spp_grid(a.spp)
    for path in a.scenes:
        scene = load_scene(path)
        if a.size:
            scene = scene.with_size(a.size, a.size)
        scene, ref, mask, region = lambertian_reference(scene, a.reference, cache_dir=a.cache)
        pm = trace_caustic_photons(scene, a.photons, seed=scene.photons.seed)
        k = scene.photons.k
        index, t_index = timed(index_of, scene, pm)
        own, t_own = timed(own_radii2, index, k)
        exact, t_exact = timed(exact_radii2, index, k)
        ratio = own / exact
        print(f"{path.stem}: {len(index):,} photons; index {t_index:.2f} s, own radii "
              f"{t_own:.2f} s, exact (cKDTree) {t_exact:.2f} s; own/exact squared radius: mean "
              f"{ratio.mean():.4f}, median {np.median(ratio):.4f}, p99 "
              f"{np.percentile(ratio, 99):.4f}, same {np.mean(abs(ratio - 1) < 1e-6):.1%}")
        rays = SceneRays(scene.objects)
        g = raycast_gbuffer(scene.camera, rays, samples=grid, seed=SPP_SEED)
        points = shading_points(scene.camera, g, scene.objects, rays, (MirrorMaterial,))
        images = {}
        for name, radii in (("own", own_radii2), ("exact", exact_radii2)):
            img = CausticPass(index, radii=radii).render(points, receiver_materials(scene.objects))
            images[name] = box_filter(img, grid)
            m = measure(images[name], ref.radiance, mask, region)
            print(f"  {name:>5} radii: flux {m['flux']:.4f}  blurred rel. RMS "
                  f"{m['blur_region']:.4f}")
        print(f"  own against exact: relative RMS {rel_rms(images['own'], images['exact'], mask):.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
