"""Convergence of the render in passes over seeds: the bias of the mean image falls with passes.

For each scene (ks = 0), at ``--size``: a Mitsuba caustic reference at ``--ref-spp`` (cached as
in tools/time_to_error.py), then ``--seeds`` renders in passes with different photon seeds.
After passes 1, 2, 4, ... each render's caustic layer is compared with the reference on the
light tracer's comparison mask, and so is the mean over the seeds (its noise is the seeds'
count smaller, so what stays is the estimate's bias): the flux ratio of the mean over seeds
(the flux bias), and the blurred relative RMS of one render and of the mean.  Fitted: the
blurred error of the mean against passes as a power law.

usage: python tools/pass_convergence.py [--scenes ring,glass] [--size 128] [--seeds 6]
                                        [--passes 16] [--photons N] [--ref-spp 4096]
                                        [--json FILE]
"""

import sys

import numpy as np

from blockhash.passes.plan import RenderPlan
from blockhash.passes.renderer import Renderer
from blockhash.passes.run import run_passes
from blockhash.studies.caustic_reference import caustic_comparison, executor, reference_options
from blockhash.studies.command import ToolParser, count, write_json
from blockhash.studies.measure import flux_ratio, masked_blur, power_law, rel_rms


def blurred(img, ref, mask):
    return rel_rms(masked_blur(img, mask), masked_blur(ref, mask), mask)


def measure(path, size, seeds, passes, ref_spp, cache, executor, photons=None):
    name = path.stem
    scene, mask, ref, _ = caustic_comparison(path, size, ref_spp, cache)
    marks = [p for p in (1, 2, 4, 8, 16, 32, 64, 128) if p <= passes]
    images = {p: [] for p in marks}
    for seed in range(1, seeds + 1):
        r = Renderer(scene, seed=seed, photons=photons, indirect=False)  # the caustic's study

        def keep(renderer, stats, elapsed, session):
            if renderer.passes in images:
                images[renderer.passes].append(renderer.film.caustic.copy())
        run_passes(r, RenderPlan(passes=passes, executor=executor), on_pass=keep)
        print(f"  {name} seed {seed}: {r.passes} passes", flush=True)
    rows = []
    for p in marks:
        mean = np.mean(images[p], axis=0)
        one = [blurred(i, ref, mask) for i in images[p]]
        rows.append({"passes": p, "flux_of_mean": flux_ratio(mean, ref, mask),
                     "blur_one_median": float(np.median(one)),
                     "blur_of_mean": blurred(mean, ref, mask)})
    law = power_law([r["passes"] for r in rows], [r["blur_of_mean"] for r in rows])[0]
    return {"scene": name, "size": size, "seeds": seeds, "rows": rows, "power_law_blur_of_mean": law}


def table(results) -> str:
    out = ["| scene | passes | flux of the mean over seeds / reference | blurred rel. RMS, one "
           "render (median) | blurred rel. RMS of the mean |", "| --- " * 5 + "|"]
    for res in results:
        for r in res["rows"]:
            out.append(f"| {res['scene']} | {r['passes']} | {r['flux_of_mean']:.4f} | "
                       f"{r['blur_one_median']:.4f} | {r['blur_of_mean']:.4f} |")
        law = res["power_law_blur_of_mean"]  # None from fewer than two pass counts
        out.append(f"| {res['scene']} | power law of the mean's blurred error | | | "
                   + ("-" if law is None else f"n^{law:.2f}") + " |")
    return "\n".join(out)


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,glass")
    p.size(128)
    p.add_argument("--seeds", type=count, default=6, help="renders, photon seeds 1..N")
    p.add_argument("--passes", type=count, default=16, help="passes of each render (default 16)")
    p.photons(None, help="photons per pass (None: the scene's)")
    reference_options(p)
    args = p.parse_args(argv)
    results = [measure(s, args.size, args.seeds, args.passes, args.ref_spp, args.cache,
                       executor(args.workers), args.photons) for s in args.scenes]
    print(table(results))
    if args.json:
        write_json(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
