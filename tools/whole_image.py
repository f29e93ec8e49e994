"""The whole image against Mitsuba 3's particle tracer: direct light, caustics and the light
between diffuse surfaces (the indirect layer, blockhash/photons/indirect.py).

For each scene of ``--scenes`` (Lambertian receivers, so Mitsuba's export drops nothing), at
``--size``: Mitsuba's ``ptracer`` over the whole scene (no albedo dimming; depth the scene's
specular chain plus 2, as the indirect photons' paths) at ``--ref-spp``, and blockhash's
render (``--passes`` passes of ``--photons`` caustic photons; the indirect photons shot a pass
as blockhash/passes/task.py shares them), compared over the receivers the camera sees
(:func:`blockhash.studies.lights.receivers_seen`: diffuse surfaces other than a lamp, away
from edges): the flux ratio and the relative RMS after a 5 x 5 box blur (and that less the
reference's own noise, from a second Mitsuba render of another seed), of the combined
image and of direct + caustic alone (what the image held before the indirect layer); the
indirect layer's flux against the in-project light tracer's (``--lt-photons``, 0 to skip);
the indirect photons shot and stored a pass and the seconds of a pass with and without them.

usage: python tools/whole_image.py [--scenes corner,venus,glass,cbox] [--size 128]
                                   [--passes 4] [--photons 1000000] [--ref-spp 1024]
                                   [--lt-photons 2000000] [--json FILE]
"""

import sys
import time

import numpy as np

import blockhash
from blockhash.frame.scene_rays import SceneRays
from blockhash.passes.plan import RenderPlan
from blockhash.reference.lighttrace import light_trace
from blockhash.reference.mitsuba import render_mitsuba, without_specular_lobes
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count, write_json
from blockhash.studies.lights import receivers_seen
from blockhash.studies.measure import box_blur_rel_rms, flux_ratio


def compare(a, ref, mask) -> tuple[float, float]:
    """(flux ratio, blurred relative RMS) of ``a`` against ``ref`` over ``mask``."""
    return flux_ratio(a, ref, mask), box_blur_rel_rms(a, ref, mask)


def measure(path, size, passes, photons, ref_spp, lt_photons) -> dict:
    scene = without_specular_lobes(load_scene(path)).with_size(size, size)
    ref, ref_s = render_mitsuba(scene, "ptracer", ref_spp)
    ref = ref.astype(np.float64)
    mask = receivers_seen(scene, SceneRays(scene.objects))
    t = time.perf_counter()
    image = blockhash.render(scene, photons=photons, plan=RenderPlan(passes=passes))
    seconds = time.perf_counter() - t
    t = time.perf_counter()
    blockhash.render(scene, photons=photons, plan=RenderPlan(passes=passes, indirect=False))
    seconds_without = time.perf_counter() - t
    row = {"scene": path.stem, "size": size, "passes": passes, "photons": photons,
           "ref_spp": ref_spp, "ref_seconds": ref_s, "pixels": int(mask.sum()),
           "seconds": seconds, "seconds_without_indirect": seconds_without,
           "indirect_note": image.info.get("indirect", "")}
    row["flux"], row["blurred"] = compare(image.combined.astype(np.float64), ref, mask)
    # the reference's own noise: a second Mitsuba render of another seed against it
    again, _ = render_mitsuba(scene, "ptracer", ref_spp, seed=7)
    row["ref_flux_noise"], noise = compare(again.astype(np.float64), ref, mask)
    row["ref_flux_noise"] = abs(row["ref_flux_noise"] - 1.0) / np.sqrt(2.0)
    row["ref_blurred_noise"] = noise / np.sqrt(2.0)
    row["blurred_less_ref_noise"] = float(np.sqrt(max(row["blurred"] ** 2 - row["ref_blurred_noise"] ** 2, 0.0)))
    row["flux_without"], row["blurred_without"] = compare(
        (image.direct + image.caustic).astype(np.float64), ref, mask)
    if image.indirect is not None and lt_photons:
        lt = light_trace(scene, lt_photons, layer="indirect")
        m = lt.comparison_mask(1)
        row["indirect_vs_light_tracer"] = float(image.indirect.astype(np.float64)[m].sum()
                                                / lt.radiance[m].sum())
        row["light_tracer_noise"] = float(np.sqrt((lt.stderr[m] ** 2).sum()) / lt.radiance[m].sum())
    return row


def table(rows) -> str:
    out = ["| scene | size | passes x photons | Mitsuba ptracer spp | whole-image flux / Mitsuba's "
           "| blurred rel. RMS (less the reference's noise; that noise) | without the indirect "
           "layer: flux, blurred | indirect flux / light tracer's (its noise) | s with / without "
           "indirect | indirect photons |", "| --- " * 10 + "|"]
    for r in rows:
        lt = (f"{r['indirect_vs_light_tracer']:.4f} ({r['light_tracer_noise']:.4f})"
              if "indirect_vs_light_tracer" in r else "-")
        out.append(f"| {r['scene']} | {r['size']} | {r['passes']} x {r['photons']:,} | "
                   f"{r['ref_spp']} | {r['flux']:.4f} | {r['blurred']:.4f} "
                   f"({r['blurred_less_ref_noise']:.4f}; {r['ref_blurred_noise']:.4f}) | "
                   f"{r['flux_without']:.4f}, {r['blurred_without']:.4f} | {lt} | "
                   f"{r['seconds']:.1f} / {r['seconds_without_indirect']:.1f} | "
                   f"{r['indirect_note']} |")
    return "\n".join(out)


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("corner,venus,glass,cbox")
    p.size(128)
    p.add_argument("--passes", type=count, default=4, help="passes of blockhash's render")
    p.photons(1_000_000, help="caustic photons per pass")
    p.add_argument("--ref-spp", type=count, default=1024, help="Mitsuba's samples per pixel")
    p.add_argument("--lt-photons", type=int, default=2_000_000,
                   help="the light tracer's photons for the indirect layer's oracle (0: skip)")
    p.json_output()
    args = p.parse_args(argv)
    rows = []
    for path in args.scenes:
        rows.append(measure(path, args.size, args.passes, args.photons, args.ref_spp,
                            args.lt_photons))
        print(f"{path.stem}: flux {rows[-1]['flux']:.4f} blurred {rows[-1]['blurred']:.4f}",
              flush=True)
        if args.json:
            write_json(args.json, rows)
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
