"""Total caustic flux of exact kNN (and BH) against the light-traced reference, ks = 0.

Checks the claim "on the ring scene with the floor's ks set to 0, exact kNN at 10^6
photons agrees with the reference within 3% in total caustic flux".  Every Phong
material's ks is set to 0 (Lambertian receivers); the caustic layer is rendered at
``--supersample`` times the size and box-filtered; exact kNN is scipy's cKDTree on the
photon map, BH the CPU reference of the caustic pass (the shader's neighbours); the
reference is :func:`blockhash.reference.lighttrace.light_trace`, cached.  Flux ratios and
blurred relative RMS are taken over the reference's comparison mask (receivers seen
directly; caustics seen in mirrors are in neither sum).

    python tools/caustic_flux_check.py scenes/ring.toml --photons 1000000,200000
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from blockhash import BlockHashIndex
from blockhash.frame.caustic import estimate_cpu, estimate_exact
from blockhash.frame.gbuffer import rasterize
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.reference.lighttrace import cached_reference, lambertian
from blockhash.scene.loader import load_scene
from blockhash.scene.materials import receiver_materials
from blockhash.scene.model import MirrorMaterial
from blockhash.studies.command import ToolParser, count, size
from blockhash.studies.density.estimates import reference_options
from blockhash.studies.measure import errors_against
from blockhash.studies.tradeoff.sweep import box_down


def main(argv=None) -> None:
    p = ToolParser(__doc__, __file__)
    p.add_argument("scene", type=p.scene, help="scene file or name under scenes/")
    p.photons([1_000_000], many=True, help="photon counts")
    p.add_argument("--size", type=size, default=(128, 128),
                   help="image size, 128x128 or 128 (default 128x128)")
    p.add_argument("--supersample", type=count, default=2)
    reference_options(p, 50_000_000, flag="--reference-photons")
    p.add_argument("--k", type=count, default=50)
    p.add_argument("--A", type=count, default=8)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--keep-ks", action="store_true", help="keep the scene's ks (default: 0)")
    args = p.parse_args(argv)
    w, h = args.size
    ss = args.supersample
    scene = load_scene(args.scene)
    shown = args.scene.relative_to(p.root) if p.root in args.scene.parents else args.scene
    if not args.keep_ks:
        scene = lambertian(scene)
    t = time.perf_counter()
    ref, path = cached_reference(scene, args.reference_photons, size=(w, h), cache_dir=args.cache)
    mask = ref.comparison_mask()
    noise = np.sqrt(np.sum(ref.stderr[mask] ** 2)) / ref.radiance[mask].sum()
    print(f"{shown} (ks {'kept' if args.keep_ks else '= 0'}), {w}x{h} (x{ss} supersampled), "
          f"reference {ref.emitted:,} photons ({path}, {time.perf_counter() - t:.0f} s), "
          f"{mask.sum():,} pixels compared, reference flux standard error {noise:.2%}")
    g = rasterize(scene.camera, scene.objects, size=(w * ss, h * ss))
    points = shading_points(scene.camera, g, scene.objects, SceneRays(scene.objects), (MirrorMaterial,))
    materials = receiver_materials(scene.objects)
    print(f"{'method':<22} {'N':>10} {'flux / reference':>17} {'rel RMS':>8} {'rel RMS (2 px blur)':>20}")
    for n in args.photons:
        photons = trace_caustic_photons(scene, n, seed=args.seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            index = BlockHashIndex(photons.positions, k=args.k, A=args.A,
                                   directions=photons.directions, normals=photons.normals,
                                   powers=photons.powers)
        for name, img in (("exact kNN (cKDTree)", estimate_exact(index, points, materials, gpu=False)),
                          (f"BH default A={args.A}", estimate_cpu(index, points, materials))):
            e = errors_against(box_down(img, ss), ref.radiance, mask, "reference")
            print(f"{name:<22} {n:>10,} {e['flux_ratio_reference']:>17.4f} "
                  f"{e['rel_rms_reference']:>8.3f} {e['rel_rms_reference_blur']:>20.3f}", flush=True)


if __name__ == "__main__":
    main()
