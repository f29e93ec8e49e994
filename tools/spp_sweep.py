"""Samples per pixel against the unbiased reference: error and time of `blockhash render`.

For each scene (Lambertian receivers: every ks set to 0, :func:`lighttrace.lambertian`)
one photon map is traced (the scene's seed, ``--photons`` stored), and the caustic layer is
rendered the way ``blockhash render`` renders it (``render_scene``, the default lookup and
estimate) at each spp.  Each image is compared with the light tracer's pixel means
(``blockhash/reference/lighttrace.py``, ``--reference`` photons shot, cached under ``--cache``) on the
pixels whose view ray meets a diffuse surface first (``comparison_mask``; pixels seen
through a mirror or glass are left out: the light tracer cannot connect a caustic to the
pinhole through a delta surface, so its caustic there is 0):

* ``flux``: caustic flux ratio, sum(render) / sum(reference);
* ``blur``: relative RMS after a Gaussian blur of 2 pixels (sigma), over the caustic region
  (``tradeoff.estimates.caustic_region``: where the blurred reference exceeds a share of
  its 99th percentile), the figure the targets name; ``blur_all`` over every compared pixel;
* ``seconds``: the render's wall time, and each stage's (``RenderResult.timings``).

    python tools/spp_sweep.py scenes/ring.toml scenes/corner.toml --spp 1,4,9,16
    python tools/spp_sweep.py scenes/venus.toml --photons 200000 --json out.json

``--size`` renders (and traces the reference) at another square size than the scene's.
The default spp (``blockhash.frame.subpixel.DEFAULT_SPP``) was chosen on ring and corner
only; venus is reported, never tuned on.
"""

from __future__ import annotations

import sys
import time

from blockhash.passes.pipeline import render_scene
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count, listing, side, write_json
from blockhash.studies.density.estimates import lambertian_reference, measure, reference_options

#: Light-tracer photons of the reference: its blurred relative noise in the caustic region
#: is printed beside every row.
REFERENCE_PHOTONS = 100_000_000


def sweep(scene_path, spps, *, photons, reference, cache, size=None, progress=print) -> list[dict]:
    scene = load_scene(scene_path)
    if size:
        scene = scene.with_size(size, size)
    name = scene_path.stem
    t = time.perf_counter()
    scene, ref, mask, region = lambertian_reference(scene, reference, cache_dir=cache)
    progress(f"{name}: reference {ref.emitted:,} photons ({time.perf_counter() - t:.0f} s), "
             f"{int(mask.sum()):,} pixels compared, {int(region.sum()):,} in the caustic region")
    pm = trace_caustic_photons(scene, photons, seed=scene.photons.seed)
    rows = []
    for spp in spps:
        t = time.perf_counter()
        r = render_scene(scene, photon_map=pm, spp=spp)
        seconds = time.perf_counter() - t
        m = measure(r.caustic, ref.radiance, mask, region)
        rows.append({"scene": name, "photons": len(pm.positions), "spp": spp,
                     "flux": m["flux"], "blur": m["blur_region"], "blur_all": m["blur"],
                     "flux_region": m["flux_region"], "seconds": seconds,
                     "timings": r.timings, "reference_photons": ref.emitted,
                     "pixels_compared": int(mask.sum()), "pixels_region": int(region.sum())})
        progress(f"  spp {spp:>3}: flux {m['flux']:.4f}  blurred rel. RMS {m['blur_region']:.4f} "
                 f"(all pixels {m['blur']:.4f})  {seconds:.1f} s  ("
                 + ", ".join(f"{k} {v:.2f}" for k, v in r.timings.items()) + ")")
    return rows


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.add_argument("scenes", nargs="+", type=p.scene,
                   help="scene files or names under scenes/")
    p.add_argument("--spp", type=listing(count), default=[1, 4, 9, 16],
                   help="comma-separated square numbers (default 1,4,9,16)")
    p.photons(1_000_000, help="photons stored")
    reference_options(p, REFERENCE_PHOTONS)
    p.add_argument("--size", type=side, default=None,
                   help="square image side, 128 or 128x128 (default the scene's)")
    p.json_output("write the rows to this JSON file")
    a = p.parse_args(argv)
    rows = []
    for s in a.scenes:
        rows += sweep(s, a.spp, photons=a.photons, reference=a.reference, cache=a.cache,
                      size=a.size)
    if a.json:
        write_json(a.json, {"command": "python tools/spp_sweep.py "
                            + " ".join(sys.argv[1:] if argv is None else argv), "rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
