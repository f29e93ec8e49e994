"""Time to equal error, as curves: blockhash's progressive render against Mitsuba 3's ptracer.

For each scene, with ks = 0 on every modified Phong material (Mitsuba has none), at
``--size``:

1. a long Mitsuba reference of the caustic layer (``ptracer`` less the specular-absorbing
   render, blockhash/reference/mitsuba.py) at ``--ref-spp``, cached in ``--cache``;
2. blockhash's progressive render (``blockhash.passes.renderer.Renderer`` with the default
   schedule, ``--photons`` per pass, in this process or ``--workers N`` local worker
   processes): after every pass its own time (from the start of the render's loop, the
   workers' start included; the metrics are computed after it) and the caustic layer's errors against the reference
   on the light tracer's comparison mask (receivers seen directly; pixels seen through a
   mirror or glass are left out, since Mitsuba's ptracer cannot reach the camera through a
   delta surface): per-pixel relative RMS, blurred relative RMS (sigma 2 px), mean FLIP, flux
   ratio, and the film's estimated relative standard error;
3. the one-pass render (``render_scene``: 9 stratified samples per pixel), for the
   default stopping rule's comparison;
4. Mitsuba's ``ptracer`` at 1, 2, 4, ... spp (independent seeds), timed as one render (what
   a user's render costs) and as the two renders of its caustic isolation, until it reaches
   blockhash's error at the longest time on every metric (or ``--max-spp``).

At each of ``--times`` the table gives Mitsuba's time to reach blockhash's error there over
that time (log-log interpolation in the ladder).  The per-pixel metric is taken less the
reference's own noise: Mitsuba's squared error at s spp is ``a / s + a / S``, ``a`` fitted to
the ladder, so blockhash's error less the reference's noise is ``sqrt(e^2 - a / S)``, reached
by Mitsuba at ``a / (e^2 - a / S)`` spp (its time from a line through the ladder).

With ``--layer whole`` the comparison is of the whole image (direct light, caustic and the
indirect layer) against a long Mitsuba ``ptracer`` render of the whole scene (no albedo
dimming), over the receivers seen directly (:func:`blockhash.studies.lights.receivers_seen`),
the FLIP column the LDR-FLIP of the tone-mapped images (one exposure, the reference's), and
Mitsuba's ladder its whole renders with each of ``--integrators``.

Also per scene: the power law of the blurred and per-pixel error against passes (fitted from
pass 2 on), the estimated error beside the measured per-pixel error, and for glass the focus
checks (the reference's brightest pixel, its 3 x 3 neighbourhood and the caustic flux).

usage: python tools/time_to_error.py [--scenes ring,venus,glass,corner] [--size 256]
                                     [--times 2,8,32] [--ref-spp 4096] [--photons N]
                                     [--passes N] [--workers N]
                                     [--json docs/time-to-error-256.json]
       python tools/time_to_error.py --from-json docs/time-to-error-256.json
"""

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from blockhash.passes.executors import InProcess
from blockhash.passes.pipeline import render_scene
from blockhash.passes.plan import RenderPlan
from blockhash.passes.renderer import Renderer
from blockhash.passes.run import run_passes
from blockhash.reference.mitsuba import mitsuba_reference, render_mitsuba
from blockhash.scene.loader import load_scene
from blockhash.studies.caustic_reference import (
    caustic_comparison,
    executor,
    reference_options,
    whole_comparison,
)
from blockhash.studies.command import ToolParser, count, listing, number, write_json
from blockhash.studies.measure import (
    flip_error,
    flux_ratio,
    ldr_flip_error,
    masked_blur,
    power_law,
    rel_rms,
)

METRICS = ("pixel", "blur", "flip")


def metrics(img, ref, mask, *, ldr: bool = False) -> dict:
    """The errors of ``img`` against ``ref`` over ``mask``; ``flip`` the HDR-FLIP of the
    caustic layer, or with ``ldr`` the LDR-FLIP of the tone-mapped whole image."""
    return {"pixel": rel_rms(img, ref, mask),
            "blur": rel_rms(masked_blur(img, mask), masked_blur(ref, mask), mask),
            "flip": (ldr_flip_error if ldr else flip_error)(img, ref, mask),
            "flux": flux_ratio(img, ref, mask)}


def crossing(errs, times, target):
    """Log-log interpolated time where the falling ``errs`` reach ``target`` (None: never)."""
    for i in range(1, len(errs)):
        if errs[i] <= target:
            e0, e1, t0, t1 = errs[i - 1], errs[i], times[i - 1], times[i]
            if e0 <= target or e0 == e1:
                return t1
            f = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e1))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    return times[0] if errs and errs[0] <= target else None


def focus(img, ref) -> dict:
    """The glass focus: blockhash over the reference at the reference's brightest pixel, in
    the 3 x 3 pixels around it (sums), over the whole image (flux)."""
    lum_ref = ref.sum(axis=2)
    r, c = np.unravel_index(np.argmax(lum_ref), lum_ref.shape)
    win = (slice(max(r - 1, 0), r + 2), slice(max(c - 1, 0), c + 2))
    lum = img.sum(axis=2)
    return {"pixel": (int(r), int(c)), "brightest": float(lum.max() / lum_ref.max()),
            "at_focus": float(lum[r, c] / lum_ref[r, c]),
            "window_3x3": float(lum[win].sum() / lum_ref[win].sum()),
            "flux": float(lum.sum() / lum_ref.sum())}


def progressive_curve(scene, ref, mask, until: float, photons, *, focus_checks: bool,
                      executor=None, passes=None, whole: bool = False):
    """Pass by pass, for ``until`` seconds (or ``passes``, the most): the render's own time
    (from the start of its loop, workers' start included; the copies of the film taken here
    left out) and its errors, computed after: of the caustic layer (rendered without the
    indirect light), or with ``whole`` of the whole image (direct, caustic and indirect)."""
    r = Renderer(scene, photons=photons, indirect=whole)
    films, aside = [], 0.0

    def keep(renderer, stats, elapsed, session):
        nonlocal aside
        t = time.perf_counter()
        film = renderer.film
        img = film.caustic
        if whole:
            img = film.direct + film.caustic + (0.0 if film.indirect is None else film.indirect)
        films.append((renderer.passes, elapsed - aside, img.astype(np.float32),
                      film.estimated_error()))
        aside += time.perf_counter() - t
    run_passes(r, RenderPlan(passes=passes, seconds=until, executor=executor or InProcess()),
               on_pass=keep)
    curve = []
    for passes, own, img, est in films:
        row = {"passes": passes, "seconds": own, "estimated_error": est,
               **metrics(img, ref, mask, ldr=whole)}
        if focus_checks:
            row["focus"] = focus(img, ref)
        curve.append(row)
        print(f"  pass {passes}: {own:.2f} s pixel {row['pixel']:.4f} blur {row['blur']:.4f} "
              f"flip {row['flip']:.4f} flux {row['flux']:.4f} est {est:.4f}", flush=True)
    return curve, dict(r.timings), r.emitted, r.stored


def at_time(curve, t):
    """The last pass that ended by ``t`` (the first pass if none did)."""
    done = [row for row in curve if row["seconds"] <= t]
    return done[-1] if done else curve[0]


def measure(path, size, ref_spp, times, max_spp, photons, cache, executor=None, passes=None,
            integrators=("ptracer",), layer: str = "caustic"):
    """The scene's blockhash curve and, per Mitsuba integrator of ``integrators``, its
    ladder and the ratios (one row each), on ``layer`` ('caustic' or 'whole')."""
    name = path.stem
    whole = layer == "whole"
    scene, mask, ref, ref_s = (whole_comparison if whole else caustic_comparison)(
        path, size, ref_spp, cache)
    render_scene(scene.with_size(32, 32), photons=20000)  # warm: compiled kernels and programs
    one = render_scene(scene, photons=photons)
    row = {"scene": name, "size": size, "ref_spp": ref_spp, "ref_seconds": ref_s, "layer": layer,
           "delta_lights": any(not hasattr(li, "radiance") for li in scene.lights),
           "one_pass": {"seconds": one.timings["total"], "spp": one.spp,
                        **metrics(one.combined if whole else one.caustic, ref, mask, ldr=whole)}}
    print(f"{name} {size}: one pass {one.timings['total']:.2f} s blur {row['one_pass']['blur']:.4f}",
          flush=True)
    curve, stages, emitted, stored = progressive_curve(scene, ref, mask, max(times) * 1.02, photons,
                                                       focus_checks=name == "glass" and not whole,
                                                       executor=executor, passes=passes,
                                                       whole=whole)
    row.update(curve=curve, stages=stages, emitted=emitted, stored=stored)
    target = {m: at_time(curve, max(times))[m] for m in METRICS}
    rows = []
    for integrator in integrators:
        ladder = []
        spp = 1
        while spp <= max_spp:
            if whole:  # one render: the user's image
                img, sec = render_mitsuba(scene, integrator, spp, seed=1000 + spp)
                mm = metrics(img, ref, mask, ldr=True)
                ladder.append({"spp": spp, "s1": sec, "s2": sec, **mm})
            else:
                m = mitsuba_reference(scene, spp, seed=1000 + spp, layers=("caustic",),
                                      integrator=integrator)
                mm = metrics(m.caustic, ref, mask)
                ladder.append({"spp": spp, "s1": m.timings[f"caustic ({integrator})"],
                               "s2": sum(m.timings.values()), **mm})
            print(f"  mitsuba {integrator} spp {spp}: {ladder[-1]['s1']:.2f} s pixel "
                  f"{mm['pixel']:.4f} blur {mm['blur']:.4f} flip {mm['flip']:.4f}", flush=True)
            if all(mm[k] <= target[k] for k in METRICS):
                break
            spp *= 2
        rows.append(analyse({**row, "integrator": integrator, "ladder": ladder}, times))
    return rows


def noise_fit(lad, k, ref_spp) -> float:
    """``a`` of Mitsuba's squared error ``a (1 / s + 1 / S)`` on metric ``k`` (it is unbiased:
    its error is its noise and the reference's), least squares over the ladder."""
    s = np.array([r["spp"] for r in lad], float)
    e2 = np.array([r[k] for r in lad]) ** 2
    basis = 1 / s + 1 / ref_spp
    return float((basis * e2).sum() / (basis * basis).sum())


def analyse(row, times):
    lad, curve, ref_spp = row["ladder"], row["curve"], row["ref_spp"]
    s = np.array([r["spp"] for r in lad], float)
    fits = {k: noise_fit(lad, k, ref_spp) for k in ("pixel", "blur")}
    row["pixel_ref_noise"] = math.sqrt(fits["pixel"] / ref_spp)
    row["blur_ref_noise"] = math.sqrt(fits["blur"] / ref_spp)
    fit1 = np.polyfit(s, [r["s1"] for r in lad], 1) if len(lad) > 1 else (lad[0]["s1"], 0.0)
    row["at"] = []
    for t in times:
        b = at_time(curve, t)
        entry = {"time": t, "passes": b["passes"], "seconds": b["seconds"]}
        for k in METRICS:
            tt = crossing([r[k] for r in lad], [r["s1"] for r in lad], b[k])
            entry[k] = b[k]
            entry[f"ratio_{k}"] = None if tt is None else tt / b["seconds"]
            # not reached by the ladder's last render: Mitsuba needs more than it took
            entry[f"ratio_{k}_above"] = lad[-1]["s1"] / b["seconds"] if tt is None else None
        for k, a in fits.items():  # the error less the reference's noise, and Mitsuba's time there
            true2 = b[k] ** 2 - a / ref_spp
            entry[f"{k}_true"] = math.sqrt(max(true2, 0.0))
            entry[f"ratio_{k}_true"] = (float(fit1[1] + fit1[0] * a / true2) / b["seconds"]
                                        if true2 > 0 else None)
        row["at"].append(entry)
    late = [r for r in curve if r["passes"] >= 2]
    for k in ("blur", "pixel"):
        row[f"power_law_{k}"] = power_law([r["passes"] for r in late], [r[k] for r in late])[0]
    return row


def tables(rows) -> str:
    def f(x, fmt=".2f"):
        return "-" if x is None else format(x, fmt)

    def ratio(e, k):
        if e[f"ratio_{k}"] is not None:
            return f"{e[f'ratio_{k}']:.2f}x"
        return f"> {e[f'ratio_{k}_above']:.2f}x" if e.get(f"ratio_{k}_above") else "-"

    def true(e, k):
        if not e[f"{k}_true"]:
            return f"{e[k]:.4f}: within the reference's noise"
        return f"{e[f'{k}_true']:.4f} ({f(e[f'ratio_{k}_true'])}x)"

    out = ["| scene | size | Mitsuba | blockhash s (passes' own) | passes | per-pixel rel. RMS less "
           "the ref.'s noise (Mitsuba's time / blockhash's) | blurred rel. RMS as measured (ratio) | "
           "blurred, less the ref.'s noise (ratio) | mean FLIP (ratio) |", "| --- " * 9 + "|"]
    if len({mitsuba(r) for r in rows}) > 1:
        out = faster(rows) + [""] + out
    once = {}  # the tables of blockhash's own curve: once per scene and size
    for r in rows:
        once.setdefault((r["scene"], r["size"]), r)
    for r in rows:
        for e in r["at"]:
            out.append(f"| {r['scene']} | {r['size']} | {mitsuba(r)} | {e['time']:g} ({e['seconds']:.1f}) | "
                       f"{e['passes']} | {true(e, 'pixel')} | {e['blur']:.4f} ({ratio(e, 'blur')}) "
                       f"| {true(e, 'blur')} | {e['flip']:.4f} ({ratio(e, 'flip')}) |")
    out += ["", "| scene | size | one pass (9 spp): s, blurred rel. RMS | progressive: passes and s "
            "to reach it | error against passes (blurred, per-pixel), power law | estimated / "
            "measured per-pixel error at the last pass | reference noise (per pixel, blurred) |",
            "| --- " * 6 + "|"]
    for r in once.values():
        one = r["one_pass"]
        reach = next((c for c in r["curve"] if c["blur"] <= one["blur"]), None)
        last = r["curve"][-1]
        out.append(f"| {r['scene']} | {r['size']} | {one['seconds']:.2f}, {one['blur']:.4f} | "
                   + (f"{reach['passes']}, {reach['seconds']:.2f} | " if reach else "not reached | ")
                   + f"n^{f(r['power_law_blur'], '.2f')}, n^{f(r['power_law_pixel'], '.2f')} | "
                   f"{last['estimated_error']:.4f} / {last['pixel']:.4f} | {r['pixel_ref_noise']:.4f}, "
                   f"{r['blur_ref_noise']:.4f} |")
    out += ["", "| scene | size | passes | s per pass | its stages (s per pass) | photons stored per "
            "second of tracing |", "| --- " * 6 + "|"]
    for r in once.values():
        n = r["curve"][-1]["passes"]
        st = r["stages"]
        stages = ", ".join(f"{k} {v / n:.2f}" for k, v in st.items() if k != "total")
        out.append(f"| {r['scene']} | {r['size']} | {n} | {st['total'] / n:.2f} | {stages} | "
                   f"{r['stored'] / st['trace']:,.0f} |")
    glass = [r for r in once.values() if r["scene"] == "glass"]
    if glass:
        out += ["", "| glass size | passes | brightest pixel / reference's | at the focus pixel | "
                "3 x 3 around it (sums) | caustic flux |", "| --- " * 6 + "|"]
        for r in glass:
            for c in (r["curve"][0], r["curve"][-1]):
                fo = c["focus"]
                out.append(f"| {r['size']} | {c['passes']} | {fo['brightest']:.3f} | "
                           f"{fo['at_focus']:.3f} | {fo['window_3x3']:.3f} | {fo['flux']:.3f} |")
    return "\n".join(out)


def integrator(text: str) -> str:
    """A Mitsuba integrator the caustic can be isolated from."""
    import argparse

    if text not in ("ptracer", "path"):
        raise argparse.ArgumentTypeError(f"{text!r}: expected ptracer or path")
    return text


def mitsuba(row) -> str:
    """The Mitsuba integrator of a row (rows of runs before there was a choice: ptracer)."""
    return row.get("integrator", "ptracer")


def misses_light(row) -> bool:
    """Whether ``row``'s Mitsuba integrator cannot render all of the light compared: the path
    tracer never reaches a point, spot or directional light over a mirror or glass (their
    caustics; its error levels off above them, which no fit of noise explains)."""
    if mitsuba(row) != "path":
        return False
    if "delta_lights" in row:
        return bool(row["delta_lights"])
    scene = Path(__file__).resolve().parents[1] / "scenes" / f"{row['scene']}.toml"
    return not scene.is_file() or any(not hasattr(li, "radiance")
                                      for li in load_scene(scene).lights)


def faster(rows) -> list[str]:
    """The table against the faster of Mitsuba's integrators at each time: per metric, the
    smaller of their times to blockhash's error over blockhash's time.  The noise-corrected
    time assumes an unbiased renderer; for an integrator that misses light
    (:func:`misses_light`) only a crossing its ladder measured counts, else its bound
    (``> r``)."""
    out = ["| scene | size | blockhash s | per-pixel (noise-corrected): the faster Mitsuba's "
           "time / blockhash's | blurred (noise-corrected) | mean FLIP |", "| --- " * 6 + "|"]
    by_scene: dict = {}
    for r in rows:
        by_scene.setdefault((r["scene"], r["size"]), []).append(r)
    for (scene, size), group in by_scene.items():
        for i, t in enumerate(e["time"] for e in group[0]["at"]):
            cells = []
            for metric in ("pixel", "blur", "flip"):
                reached, bounds = [], []
                for r in group:
                    e = r["at"][i]
                    value = e.get(f"ratio_{metric}_true") if metric != "flip" else e.get("ratio_flip")
                    trusted = e.get(f"ratio_{metric}") is not None or not misses_light(r)
                    if value is not None and trusted:
                        reached.append((value, mitsuba(r)))
                    elif e.get(f"ratio_{metric}_above"):
                        bounds.append((e[f"ratio_{metric}_above"], mitsuba(r)))
                if reached:
                    cells.append(f"{min(reached)[0]:.2f}x ({min(reached)[1]})")
                elif bounds:
                    cells.append(f"> {min(bounds)[0]:.2f}x ({min(bounds)[1]})")
                else:
                    cells.append("-")
            out.append(f"| {scene} | {size} | {t:g} | " + " | ".join(cells) + " |")
    return out


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,venus,glass,corner")
    p.size(256)
    p.add_argument("--times", type=listing(number), default=None, help="blockhash times in s "
                   "(default 2,8,32 at 256 and below, else 8,32,128)")
    p.add_argument("--max-spp", type=count, default=4096, help="the ladder's last spp")
    p.photons(None, help="photons per pass (None: the scene's)")
    p.add_argument("--passes", type=count, help="the most passes of the progressive render "
                   "(default: as many as the longest of --times allows)")
    p.add_argument("--layer", choices=("caustic", "whole"), default="caustic",
                   help="what is compared: the caustic layer (default; against Mitsuba's "
                   "isolated caustic) or the whole image (direct, caustic and indirect, against "
                   "Mitsuba's whole render over the receivers seen directly; FLIP on the "
                   "tone-mapped images)")
    p.add_argument("--integrators", type=listing(integrator), default=["ptracer"],
                   help="Mitsuba's integrators to race, each isolating the caustic as the "
                   "reference does: ptracer, path (default ptracer)")
    reference_options(p)
    p.add_argument("--from-json", type=Path, help="print the tables of an earlier run's JSON "
                   "(no rendering)")
    args = p.parse_args(argv)
    times = args.times or ([2.0, 8.0, 32.0] if args.size <= 256 else [8.0, 32.0, 128.0])
    if args.from_json:
        rows = [analyse(r, [e["time"] for e in r["at"]])
                for r in json.loads(args.from_json.read_text())]
    else:
        rows = []
        for s in args.scenes:
            rows += measure(s, args.size, args.ref_spp, times, args.max_spp, args.photons,
                            args.cache, executor(args.workers), args.passes, args.integrators,
                            args.layer)
            if args.json:  # after every scene: a long run keeps what it measured
                write_json(args.json, rows)
    print(tables(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
