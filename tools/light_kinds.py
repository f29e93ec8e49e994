"""The kinds of light: photons stored per photon shot and per second for each, and the area and
directional lights' scenes against Mitsuba 3.

1. For each scene of ``--scenes`` (default the ring's point light, the Cornell box's area
   light, the sunlit glass ball's directional light): pass 0 traced to ``--photons`` stored
   photons; the photons shot, the share stored, stored photons per second of tracing, and
   what the others met (missed everything, met a diffuse surface first, left behind an area
   light's face or outside a spot's cone, escaped after a mirror, absorbed).
2. For each scene of ``--compare`` (default cbox and sun; Lambertian receivers, so Mitsuba's
   export drops nothing), at ``--size``: blockhash's render (``--passes`` passes of
   ``--pass-photons`` photons) against Mitsuba's caustic reference (``ptracer``, the
   isolation of ``blockhash reference --engine mitsuba``, ``--ref-spp``): caustic flux ratio
   over the light tracer's comparison mask (receivers seen directly) and the relative RMS
   after a 5 x 5 box blur on the caustic's pixels (above 5% of the reference's blurred peak);
   and the direct layer against Mitsuba's ``path`` at depth 2 (emitters seen and lit
   directly, ``--ref-spp``) over the receivers the camera sees
   (:func:`blockhash.studies.lights.receivers_seen`): its total after 64 passes and its
   relative RMS after 4 and 64 passes (the soft shadows converging).
3. With ``--png-dir``: each compared scene's blockhash render (``--passes`` passes) and
   Mitsuba's ``path`` render of the whole image (``--ref-spp``, depth the scene's specular
   chain plus 2) with one exposure, ``NAME.png`` and ``NAME-mitsuba.png``.

usage: python tools/light_kinds.py [--scenes ring,cbox,sun] [--photons 1000000]
                                   [--compare cbox,sun] [--size 128] [--passes 4]
                                   [--pass-photons 1000000] [--ref-spp 1024]
                                   [--png-dir docs] [--json FILE]
"""

import sys
from pathlib import Path

import numpy as np

import blockhash
from blockhash.evaluate.images import srgb, white_point, write_rgb8
from blockhash.frame.scene_rays import SceneRays
from blockhash.passes.plan import RenderPlan
from blockhash.reference.lighttrace import light_trace
from blockhash.reference.mitsuba import mitsuba_reference, render_mitsuba, without_specular_lobes
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count, write_json
from blockhash.studies.lights import efficiency, soft_shadow_errors
from blockhash.studies.measure import box_blur_rel_rms, flux_ratio

FATES = ("missed", "direct", "outside_spot", "escaped", "absorbed")


def agreement(path, size: int, passes: int, photons: int, ref_spp: int, png_dir) -> dict:
    scene = without_specular_lobes(load_scene(path)).with_size(size, size)
    ref = mitsuba_reference(scene, ref_spp, layers=("caustic",)).caustic.astype(np.float64)
    mask = light_trace(scene, 1000).comparison_mask(1)
    image = blockhash.render(scene, photons=photons, plan=RenderPlan(passes=passes))
    ours = image.caustic.astype(np.float64)
    row = {"scene": path.stem, "size": size, "passes": passes, "photons": photons,
           "ref_spp": ref_spp, "caustic_flux": flux_ratio(ours, ref, mask),
           "caustic_blurred_rel_rms": box_blur_rel_rms(ours, ref, mask, bright=0.05)}
    direct_ref, _ = render_mitsuba(scene, "path", ref_spp, max_depth=2)
    row["direct"] = soft_shadow_errors(scene, direct_ref.astype(np.float64), SceneRays(scene.objects))
    if png_dir is not None:
        whole, _ = render_mitsuba(scene, "path", ref_spp)
        white = white_point(image.combined)
        png_dir.mkdir(parents=True, exist_ok=True)
        for name, img in ((path.stem, image.combined), (f"{path.stem}-mitsuba", whole)):
            write_rgb8(png_dir / f"{name}.png", np.round(srgb(img, white=white) * 255).astype(np.uint8))
    return row


def tables(kinds, rows) -> str:
    out = ["| scene | lights | photons shot | stored | stored / shot | stored per second of "
           "tracing | shot that missed, met a diffuse surface first, left behind the light, "
           "escaped, were absorbed |", "| --- " * 7 + "|"]
    for k in kinds:
        fates = ", ".join(f"{k['fates'].get(f, 0) / max(k['emitted'], 1):.1%}" for f in FATES)
        out.append(f"| {k['scene']} | {', '.join(k['lights'])} | {k['emitted']:,} | "
                   f"{k['stored']:,} | {k['stored_fraction']:.3f} | {k['stored_per_second']:,.0f} "
                   f"| {fates} |")
    if rows:
        out += ["", "| scene | size | passes x photons | Mitsuba spp | caustic flux / Mitsuba's "
                "| caustic blurred rel. RMS | direct / Mitsuba's path (receivers, 64 passes) | "
                "direct rel. RMS at 4 passes | at 64 | 64 / 4 |", "| --- " * 10 + "|"]
        for r in rows:
            d = r["direct"]
            e4, e64 = d["rel_rms"]
            out.append(f"| {r['scene']} | {r['size']} | {r['passes']} x {r['photons']:,} | "
                       f"{r['ref_spp']} | {r['caustic_flux']:.4f} | "
                       f"{r['caustic_blurred_rel_rms']:.4f} | {d['ratio']:.4f} | {e4:.4f} | "
                       f"{e64:.4f} | {e64 / e4:.3f} |")
    return "\n".join(out)


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,cbox,sun")
    p.photons(1_000_000, help="photons stored in the efficiency pass")
    p.scenes("cbox,sun", flag="--compare", help="scenes compared with Mitsuba (empty: none)")
    p.size(128)
    p.add_argument("--passes", type=count, default=4, help="passes of the compared render")
    p.photons(1_000_000, flag="--pass-photons", help="photons per pass of the compared render")
    p.add_argument("--ref-spp", type=count, default=1024, help="Mitsuba's samples per pixel")
    p.add_argument("--png-dir", type=Path, help="write blockhash's and Mitsuba's images here")
    p.json_output()
    args = p.parse_args(argv)
    kinds = []
    for path in args.scenes:
        kinds.append({"scene": path.stem, **efficiency(load_scene(path), args.photons)})
        print(f"{path.stem}: {kinds[-1]['stored_fraction']:.3f} stored, "
              f"{kinds[-1]['stored_per_second']:,.0f} a second", flush=True)
    rows = [agreement(path, args.size, args.passes, args.pass_photons, args.ref_spp, args.png_dir)
            for path in args.compare]
    if args.json:
        write_json(args.json, {"kinds": kinds, "agreement": rows})
    print(tables(kinds, rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
