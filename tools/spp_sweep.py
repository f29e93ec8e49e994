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

The default spp (``blockhash.frame.subpixel.DEFAULT_SPP``) was chosen on ring and corner
only; venus is reported, never tuned on.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

from blockhash.passes.pipeline import render_scene
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.reference.lighttrace import cached_reference, lambertian
from blockhash.scene.loader import load_scene
from blockhash.studies.estimates import caustic_region, measure

#: Light-tracer photons of the reference: its blurred relative noise in the caustic region
#: is printed beside every row.
REFERENCE_PHOTONS = 100_000_000


def sweep(scene_path, spps, *, photons, reference, cache, progress=print) -> list[dict]:
    scene = lambertian(load_scene(scene_path))
    name = Path(scene_path).stem
    t = time.perf_counter()
    ref, _ = cached_reference(scene, reference, cache_dir=cache, progress=False)
    mask = ref.comparison_mask()
    region = caustic_region(ref.radiance, mask)
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
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--spp", default="1,4,9,16", help="comma-separated square numbers")
    ap.add_argument("--photons", type=float, default=1e6, help="photons stored (default 1e6)")
    ap.add_argument("--reference", type=float, default=REFERENCE_PHOTONS,
                    help="light-tracer photons shot for the reference (default %(default).0e)")
    ap.add_argument("--cache", default=str(Path.home() / ".cache" / "blockhash"))
    ap.add_argument("--json", help="write the rows to this JSON file")
    a = ap.parse_args(argv)
    rows = []
    for s in a.scenes:
        rows += sweep(s, [int(x) for x in a.spp.split(",")], photons=int(a.photons),
                      reference=int(a.reference), cache=a.cache)
    if a.json:
        Path(a.json).write_text(json.dumps({"command": "python tools/spp_sweep.py "
                                            + " ".join(argv or sys.argv[1:]), "rows": rows},
                                           indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
