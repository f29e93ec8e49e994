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
all its threads (Dr.Jit's LLVM backend and blockhash's numba, embree and llvmpipe).

The reference's own noise is in every error measured against it.  Mitsuba's is noise only
(it is unbiased), so its squared error at s spp is ``a / s + a / S`` (S the reference's
spp); ``a`` is fitted to the ladder by least squares.  Then blockhash's error less the
reference's noise is ``e^2 - a / S``, Mitsuba reaches that at ``s* = a / (e^2 - a / S)``
spp, and its time there comes from a straight line through the ladder's (spp, seconds).
The table gives both: the crossing as measured (against the noisy reference) and the one
with the reference's noise taken out; where blockhash's error is within the reference's
noise, the latter is a lower bound.

usage: python tools/time_to_error.py [--scenes ring,venus,glass,corner] [--size 512]
                                     [--ref-spp 1024] [--spp N] [--photons N]
                                     [--json docs/time-to-error.json]
       python tools/time_to_error.py --from-json docs/time-to-error.json
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

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


def analyse(row) -> dict:
    """Fill ``row``'s crossings (module docstring) from its ladder."""
    lad = row["mitsuba"]
    spp = np.array([r["spp"] for r in lad], dtype=np.float64)
    err2 = np.array([r["rel_rms_blur"] for r in lad]) ** 2
    secs = np.array([r["seconds"] for r in lad])
    e = row["blockhash_rel_rms_blur"]
    t_eq = time_at(list(np.sqrt(err2)), list(secs), e)
    row["mitsuba_seconds_at_equal_error"] = t_eq
    row["ratio"] = t_eq / row["blockhash_seconds"] if t_eq is not None else None
    basis = 1.0 / spp + 1.0 / row["ref_spp"]
    a = float(np.sum(basis * err2) / np.sum(basis * basis))
    floor2 = a / row["ref_spp"]
    row["reference_noise"] = math.sqrt(floor2)
    true2 = e * e - floor2
    slope, icept = np.polyfit(spp, secs, 1) if len(spp) > 1 else (secs[0] / spp[0], 0.0)
    if true2 > 0:
        s_star = a / true2
        row["blockhash_error_less_reference_noise"] = math.sqrt(true2)
        row["mitsuba_spp_at_equal_true_error"] = s_star
        row["mitsuba_seconds_at_equal_true_error"] = float(icept + slope * s_star)
        row["ratio_true"] = row["mitsuba_seconds_at_equal_true_error"] / row["blockhash_seconds"]
    else:
        s_star = None
        row["blockhash_error_less_reference_noise"] = 0.0
        row["mitsuba_spp_at_equal_true_error"] = None
        row["mitsuba_seconds_at_equal_true_error"] = None
        row["ratio_true"] = None
    return row


def measure(name, size, ref_spp, max_spp, spp=None, photons=None):
    scene = without_specular_lobes(load_scene(Path("scenes") / f"{name}.toml")).with_size(size, size)
    mask = light_trace(scene, 1000).comparison_mask(1)
    t = time.perf_counter()
    ref = mitsuba_reference(scene, ref_spp, seed=1, layers=("caustic",)).caustic
    ref_s = time.perf_counter() - t
    bh = render_scene(scene, spp=spp, photons=photons)
    bh_s = bh.timings["total"]
    bh_err = blurred(bh.caustic, ref, mask)
    row = {"scene": name, "size": size, "ref_spp": ref_spp, "ref_seconds": ref_s, "spp": bh.spp,
           "photons": bh.info.get("photons_stored"),
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
    analyse(row)
    t_eq = row["mitsuba_seconds_at_equal_error"]
    print(f"{name}: blockhash {bh_s:.2f} s at blurred rel RMS {bh_err:.4f} (flux "
          f"{row['blockhash_flux_ratio']:.4f}); mitsuba ptracer "
          + (f"{t_eq:.2f} s at equal error: ratio {row['ratio']:.2f}x" if t_eq else
             f"does not reach it by {max_spp} spp"), flush=True)
    return row


def table(rows) -> str:
    def f(x, fmt):
        return "-" if x is None else format(x, fmt)

    out = ["| scene | photons | spp | blockhash s | flux | blurred rel RMS (less the reference's noise) | "
           "reference noise | Mitsuba s at equal error, measured | ratio | Mitsuba spp and s at "
           "equal error, noise taken out | ratio |", "| --- " * 11 + "|"]
    for r in rows:
        out.append(f"| {r['scene']} | {f(r.get('photons'), ',')} | {r.get('spp', '-')} | "
                   f"{r['blockhash_seconds']:.2f} | "
                   f"{r['blockhash_flux_ratio']:.3f} | {r['blockhash_rel_rms_blur']:.4f} "
                   f"({r['blockhash_error_less_reference_noise']:.4f}) | "
                   f"{r['reference_noise']:.4f} | {f(r['mitsuba_seconds_at_equal_error'], '.2f')} | "
                   f"{f(r['ratio'], '.2f')}x | {f(r['mitsuba_spp_at_equal_true_error'], '.0f')}, "
                   f"{f(r['mitsuba_seconds_at_equal_true_error'], '.2f')} | "
                   f"{f(r['ratio_true'], '.2f')}x |")
    return "\n".join(out)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default="ring,venus,glass,corner")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--max-spp", type=int, default=256, help="the ladder's last spp")
    p.add_argument("--spp", type=int, help="blockhash's samples per pixel (default: the scene's)")
    p.add_argument("--photons", type=int, help="blockhash's photons (default: the scene's)")
    p.add_argument("--json")
    p.add_argument("--from-json", help="print the table of an earlier run's JSON (no rendering)")
    args = p.parse_args(argv)
    if args.from_json:
        rows = [analyse(r) for r in json.loads(Path(args.from_json).read_text())]
    else:
        rows = [measure(s, args.size, args.ref_spp, args.max_spp, args.spp, args.photons)
                for s in args.scenes.split(",")]
    print(table(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
