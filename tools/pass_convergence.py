"""Convergence of the render in passes over seeds: the bias of the mean image falls with passes.

For each scene (ks = 0), at ``--size``: a Mitsuba caustic reference at ``--ref-spp`` (cached as
in tools/time_to_error.py), then ``--seeds`` renders in passes with different photon seeds.
After passes 1, 2, 4, ... each render's caustic layer is compared with the reference on the
light tracer's comparison mask, and so is the mean over the seeds (its noise is the seeds'
count smaller, so what stays is the estimate's bias): the flux ratio of the mean over seeds
(the flux bias), and the blurred relative RMS of one render and of the mean.  Fitted: the
blurred error of the mean against passes as a power law.

usage: python tools/pass_convergence.py [--scenes ring,glass] [--size 128] [--seeds 6]
                                        [--passes 16] [--ref-spp 4096] [--json FILE]
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from blockhash.passes.executors import InProcess, LocalWorkers
from blockhash.passes.plan import RenderPlan
from blockhash.passes.renderer import Renderer
from blockhash.passes.run import run_passes
from blockhash.reference.lighttrace import light_trace
from blockhash.reference.mitsuba import cached_caustic, without_specular_lobes
from blockhash.scene.loader import load_scene
from blockhash.studies.measure import flux_ratio, masked_blur, power_law, rel_rms

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def blurred(img, ref, mask):
    return rel_rms(masked_blur(img, mask), masked_blur(ref, mask), mask)


def measure(name, size, seeds, passes, ref_spp, cache, executor):
    scene = without_specular_lobes(load_scene(SCENES / f"{name}.toml")).with_size(size, size)
    mask = light_trace(scene, 1000).comparison_mask(1)
    ref, _ = cached_caustic(scene, name, size, ref_spp, cache)
    marks = [p for p in (1, 2, 4, 8, 16, 32, 64, 128) if p <= passes]
    images = {p: [] for p in marks}
    for seed in range(1, seeds + 1):
        r = Renderer(scene, seed=seed)

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
        out.append(f"| {res['scene']} | power law of the mean's blurred error | | | "
                   f"n^{res['power_law_blur_of_mean']:.2f} |")
    return "\n".join(out)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default="ring,glass")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--seeds", type=int, default=6)
    p.add_argument("--passes", type=int, default=16)
    p.add_argument("--ref-spp", type=int, default=4096)
    p.add_argument("--cache", default=str(Path.home() / ".cache" / "blockhash" / "references"))
    p.add_argument("--workers", type=int, default=0, help="local worker processes for each "
                   "render's passes (0: in this process)")
    p.add_argument("--json")
    args = p.parse_args(argv)
    executor = LocalWorkers(args.workers) if args.workers else InProcess()
    results = [measure(s, args.size, args.seeds, args.passes, args.ref_spp, Path(args.cache), executor)
               for s in args.scenes.split(",")]
    print(table(results))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
