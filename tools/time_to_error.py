"""Time to equal error: blockhash's default render against Mitsuba 3's particle tracer.

For each scene, with ks = 0 on every modified Phong material (Mitsuba has none):

1. a long Mitsuba reference of the caustic layer (``ptracer`` less the specular-absorbing
   render, blockhash/reference/mitsuba.py) at ``--ref-spp`` samples per pixel;
2. blockhash's default render (``render_scene`` with the scene's settings): its wall time
   (everything: trace, index, radii, G-buffer, direct light, caustic pass), flux ratio and
   blurred relative RMS of the caustic layer against the reference, on the light tracer's
   comparison mask (receivers seen directly);
3. Mitsuba's ``ptracer`` at 1, 2, 4, ... samples per pixel (an independent seed), the time
   of both renders the caustic layer needs, until its blurred relative RMS is at most
   blockhash's; the time at equal error is interpolated log-log between the two spp that
   bracket it.

The ratio is Mitsuba's time at equal error over blockhash's.  Both run on this machine with
all its threads (Dr.Jit's LLVM backend and blockhash's numba, embree and llvmpipe).  The
reference's own noise sets a floor on the error both can reach; the table reports it (the
blurred relative RMS of a second reference of the same spp against the first, divided by
sqrt 2).

usage: python tools/time_to_error.py [--scenes ring,venus,glass,corner] [--size 512]
                                     [--ref-spp 1024] [--json docs/time-to-error.json]
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

from blockhash.frame.pipeline import render_scene
from blockhash.reference.lighttrace import light_trace
from blockhash.reference.mitsuba import mitsuba_reference, without_specular_lobes
from blockhash.scene.loader import load_scene
from blockhash.studies.measure import flux_ratio, masked_blur, rel_rms


def blurred(image, truth, mask) -> float:
    return rel_rms(masked_blur(image, mask), masked_blur(truth, mask), mask)


def time_at(errors, times, target):
    """Log-log interpolated time where the falling ``errors`` reach ``target`` (None when
    they never do)."""
    for i in range(1, len(errors)):
        if errors[i] <= target:
            e0, e1, t0, t1 = errors[i - 1], errors[i], times[i - 1], times[i]
            if e0 <= target or e0 == e1:
                return t1
            f = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e1))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    return times[0] if errors and errors[0] <= target else None


def measure(name, size, ref_spp, max_spp):
    scene = without_specular_lobes(load_scene(Path("scenes") / f"{name}.toml")).with_size(size, size)
    mask = light_trace(scene, 1000).comparison_mask(1)
    t = time.perf_counter()
    ref = mitsuba_reference(scene, ref_spp, seed=1, layers=("caustic",)).caustic
    ref_s = time.perf_counter() - t
    bh = render_scene(scene)
    bh_s = bh.timings["total"]
    bh_err = blurred(bh.caustic, ref, mask)
    row = {"scene": name, "size": size, "ref_spp": ref_spp, "ref_seconds": ref_s,
           "blockhash_seconds": bh_s, "blockhash_stages": bh.timings,
           "blockhash_flux_ratio": flux_ratio(bh.caustic, ref, mask),
           "blockhash_rel_rms_blur": bh_err, "mitsuba": []}
    spp = 1
    while spp <= max_spp:
        m = mitsuba_reference(scene, spp, seed=1000 + spp, layers=("caustic",))
        row["mitsuba"].append({"spp": spp, "seconds": sum(m.timings.values()),
                               "rel_rms_blur": blurred(m.caustic, ref, mask),
                               "flux_ratio": flux_ratio(m.caustic, ref, mask)})
        print(f"  {name} mitsuba spp {spp}: {row['mitsuba'][-1]['seconds']:.2f} s, blurred rel "
              f"RMS {row['mitsuba'][-1]['rel_rms_blur']:.4f} (blockhash {bh_err:.4f})", flush=True)
        if row["mitsuba"][-1]["rel_rms_blur"] <= bh_err:
            break
        spp *= 2
    errs = [r["rel_rms_blur"] for r in row["mitsuba"]]
    times = [r["seconds"] for r in row["mitsuba"]]
    t_eq = time_at(errs, times, bh_err)
    row["mitsuba_seconds_at_equal_error"] = t_eq
    row["ratio"] = t_eq / bh_s if t_eq is not None else None
    print(f"{name}: blockhash {bh_s:.2f} s at blurred rel RMS {bh_err:.4f} (flux "
          f"{row['blockhash_flux_ratio']:.4f}); mitsuba ptracer "
          + (f"{t_eq:.2f} s at equal error: ratio {row['ratio']:.2f}x" if t_eq else
             f"does not reach it by {max_spp} spp"), flush=True)
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default="ring,venus,glass,corner")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--max-spp", type=int, default=256, help="the ladder's last spp")
    p.add_argument("--json")
    args = p.parse_args(argv)
    rows = [measure(s, args.size, args.ref_spp, args.max_spp) for s in args.scenes.split(",")]
    print(f"\n| scene | blockhash s | flux | blurred rel RMS | Mitsuba ptracer s at equal error | "
          f"ratio |\n| --- | --- | --- | --- | --- | --- |")
    for r in rows:
        t = r["mitsuba_seconds_at_equal_error"]
        print(f"| {r['scene']} | {r['blockhash_seconds']:.2f} | {r['blockhash_flux_ratio']:.3f} | "
              f"{r['blockhash_rel_rms_blur']:.4f} | {t:.2f} | {r['ratio']:.2f}x |" if t else
              f"| {r['scene']} | {r['blockhash_seconds']:.2f} | {r['blockhash_flux_ratio']:.3f} | "
              f"{r['blockhash_rel_rms_blur']:.4f} | > {args.max_spp} spp | - |")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
