"""The done-when check of the caustic estimate: pixel means by stratified jitter, with errors.

The light tracer's reference (:mod:`blockhash.reference.lighttrace`) is the caustic radiance's
mean over each pixel's footprint.  The estimate is a function of the shading point; its
pixel mean must be integrated by sampling.  Where the caustic is much sharper than a pixel
(the fold lines of the cardioid on venus's chest, far thinner than its 3 mm pixels at
128 x 128), a regular grid of shading points (the rasteriser's, as the trade study uses)
aliases: its flux moves by several percent with the number of points per
pixel.  Here each pixel's mean comes instead from

1. **stratified jitter**, S x S cells per pixel and one uniform point in each
   (:mod:`blockhash.frame.subpixel`): an unbiased estimate of the pixel mean for any
   caustic, on the same film footprint as the reference's pixels;
2. **refinement**: the ``refine`` pixels whose S x S values spread the most (the few that
   a fold line or the cusp crosses) are estimated again with fresh jittered points,
   ``refine_samples`` squared per pixel, and that estimate replaces theirs.  It is
   independent of the first pass, so the mean stays unbiased and only its variance falls.

Each jitter seed gives one image; the seeds' spread gives the uncertainty of each
measure (mean and standard error over seeds).  Beside it the study records the same
photons splatted into their pixels by the light tracer (``splat``: the photon map traced
again with its own seed and emitted count, so the same photons, each counted in the
pixel it lands in), i.e. the flux an estimate that conserved the photons' power would
show, and the regular grid's figures at the same S.
"""

from __future__ import annotations

import math
import time

import numpy as np

from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.frame.subpixel import raycast_gbuffer
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.reference.lighttrace import cached_reference, lambertian, light_trace
from blockhash.scene.materials import receiver_materials
from blockhash.scene.model import MirrorMaterial
from blockhash.studies.density.estimates import (
    caustic_region,
    estimate_images,
    measure,
    scene_points,
    searches,
    upsample,
)
from blockhash.studies.measure import flux_ratio
from blockhash.studies.tradeoff.sweep import box_down

#: Pixels estimated again, and their shading points per pixel along each axis.
REFINE = 100
REFINE_SAMPLES = 32
#: The done-when targets: flux within 1 % of the reference, blurred rel. RMS <= 5 % (region).
FLUX_TOL = 0.01
RMS_MAX = 0.05


def options():
    """The paper's estimate, the k-nearest estimate at its best (unbiased form, cone filter,
    normal test) and the default (the conserving estimate), as the summary tables compare
    them."""
    return [EstimateOptions(estimate="paper", filter="none", normal_cos=None),
            EstimateOptions(estimate="unbiased"), EstimateOptions()]


def refine_seed(seed: int) -> int:
    """The jitter seed of the refinement pass of ``seed`` (independent of the first pass)."""
    return int(np.random.SeedSequence([int(seed), 1]).generate_state(1, np.uint64)[0] >> 1)


def pixel_means(scene, index, rays, materials, search, k, opts, mask, *, size, samples, seed,
                refine=REFINE, refine_samples=REFINE_SAMPLES):
    """(h, w, 3) pixel means of each of ``opts`` inside ``mask`` (module docstring; ``seed``
    None: the rasterised regular grid, no refinement), and the pixels refined."""
    s = int(samples)
    points = scene_points(scene, size, s, seed, rays)
    fine = estimate_images(index, points, materials, search, k, opts, only=upsample(mask, s))
    means = [box_down(f, s) for f in fine]
    if seed is None or not refine or s < 2:
        return means, 0
    h, w = mask.shape
    sel = opts.index(EstimateOptions()) if EstimateOptions() in opts else -1  # the default's spread
    per_pixel = fine[sel].sum(axis=2).reshape(h, s, w, s)
    var = np.where(mask, per_pixel.var(axis=(1, 3), ddof=1) / (s * s), 0.0).ravel()
    top = np.argsort(var)[::-1][:int(refine)]
    top = top[var[top] > 0]
    if not len(top):
        return means, 0
    r = int(refine_samples)
    g = raycast_gbuffer(scene.camera, rays, size=size, samples=r, seed=refine_seed(seed),
                        pixels=np.stack([top // w, top % w], axis=1))
    pts = shading_points(scene.camera, g, scene.objects, rays, (MirrorMaterial,))
    for m, img in zip(means, estimate_images(index, pts, materials, search, k, opts)):
        m.reshape(-1, 3)[top] = img.reshape(len(top), r, r, 3).mean(axis=(1, 2))
    return means, len(top)


def done_when_study(scene, *, photons=1_000_000, ks=(50,), size=(128, 128), samples=8,
                    seeds=tuple(range(1, 9)), refine=REFINE, refine_samples=REFINE_SAMPLES,
                    search_kinds=("bh",), estimate_options=None, reference_photons=50_000_000,
                    A=8, cache_dir=None, progress=print) -> dict:
    """Rows of :func:`blockhash.studies.density.estimates.measure` per (k, search, seed, option) for one scene with
    ks = 0, one photon map of ``photons`` (the scene's seed); seed None is the regular grid."""
    scene = lambertian(scene)
    name = scene.path.stem if scene.path else "?"
    t0 = time.perf_counter()
    ref, path = cached_reference(scene, reference_photons, size=size, cache_dir=cache_dir)
    mask = ref.comparison_mask()
    region = caustic_region(ref.radiance, mask)
    pm = trace_caustic_photons(scene, photons, seed=scene.photons.seed)
    splat = light_trace(scene, pm.emitted, seed=scene.photons.seed, size=size)
    se = ref.stderr[..., 0]
    info = {"scene": name, "photons": photons, "emitted": pm.emitted, "size": list(size),
            "samples": samples, "refine": refine, "refine_samples": refine_samples, "A": A,
            "reference": {"photons": ref.emitted, "cache": str(path) if path else None,
                          "pixels_compared": int(mask.sum()), "pixels_region": int(region.sum()),
                          "flux_rel_se_region": float(np.sqrt((se[region] ** 2).sum())
                                                      / ref.radiance[..., 0][region].sum())},
            "splat": {"flux": flux_ratio(splat.radiance, ref.radiance, mask),
                      "flux_region": flux_ratio(splat.radiance, ref.radiance, region)}}
    progress(f"{name}: reference {ref!r}; photons {pm!r}; splat/ref {info['splat']['flux']:.4f} "
             f"({time.perf_counter() - t0:.0f} s)")
    rays = SceneRays(scene.objects)
    materials = receiver_materials(scene.objects)
    opts = options() if estimate_options is None else list(estimate_options)
    rows = []
    for k in ks:
        index = BlockHashIndex(pm.positions, k=k, A=A, directions=pm.directions,
                               normals=pm.normals, powers=pm.powers)
        find = searches(index, k, A)
        for kind in search_kinds:
            for seed in (None, *seeds):
                t = time.perf_counter()
                means, refined = pixel_means(scene, index, rays, materials, find[kind], k, opts,
                                             mask, size=size, samples=samples, seed=seed,
                                             refine=refine, refine_samples=refine_samples)
                for opt, img in zip(opts, means):
                    row = {"scene": name, "k": k, "search": kind, "seed": seed,
                           "option": opt.label, "refined": refined,
                           **measure(img, ref.radiance, mask, region),
                           "flux_splat": flux_ratio(img, splat.radiance, mask)}
                    rows.append(row)
                    if seed is not None:
                        row["image"] = img  # for the seeds' mean image, dropped from the JSON
                progress(f"  k={k} {kind} seed={seed} "
                         + " | ".join(f"{r['option']} flux {r['flux']:.4f} ({r['flux_region']:.4f}) "
                                      f"blur {r['blur']:.4f} ({r['blur_region']:.4f})"
                                      for r in rows[-len(opts):])
                         + f" ({time.perf_counter() - t:.0f} s)")
    _mean_images(rows, ref, mask, region)
    return {**info, "rows": rows}


def _mean_images(rows, ref, mask, region):
    """Per (k, search, option): a row 'mean' of the mean image over the seeds."""
    groups = {}
    for r in rows:
        if "image" in r:
            groups.setdefault((r["k"], r["search"], r["option"]), []).append(r.pop("image"))
    for (k, kind, label), imgs in groups.items():
        img = np.mean(imgs, axis=0)
        rows.append({"scene": rows[0]["scene"], "k": k, "search": kind, "seed": "mean",
                     "option": label, "refined": None, "seeds": len(imgs),
                     **measure(img, ref.radiance, mask, region)})


MEASURES = ("flux", "flux_region", "blur", "blur_region")


def summary(study) -> list[dict]:
    """Per (k, search, option): each measure's mean and standard error over the seeds, the
    regular grid's value and the measure of the seeds' mean image."""
    out = {}
    for r in study["rows"]:
        key = (r["k"], r["search"], r["option"])
        s = out.setdefault(key, {"scene": study["scene"], "k": r["k"], "search": r["search"],
                                 "option": r["option"], "seeds": [], "regular": None, "pooled": None})
        if r["seed"] is None:
            s["regular"] = {m: r[m] for m in MEASURES}
        elif r["seed"] == "mean":
            s["pooled"] = {m: r[m] for m in MEASURES}
        else:
            s["seeds"].append(r)
    for s in out.values():
        rows = s.pop("seeds")
        s["n_seeds"] = len(rows)
        for m in MEASURES:
            v = np.array([r[m] for r in rows], float)
            s[m] = float(v.mean()) if len(v) else math.nan
            s[m + "_se"] = float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else math.nan
    return list(out.values())


def verdict(s, reference_se: float = 0.0) -> tuple[str, str]:
    """('yes' | 'no' | 'undecided') for the flux (region and whole area) and the RMS (region),
    each at two standard errors: the seeds' and, for the flux, the reference's own relative
    standard error ``reference_se`` in quadrature."""
    flux = []
    for m in ("flux", "flux_region"):
        e = math.hypot(s[m + "_se"], s[m] * reference_se)
        lo, hi = s[m] - 2 * e, s[m] + 2 * e
        flux.append("yes" if 1 - FLUX_TOL <= lo and hi <= 1 + FLUX_TOL else
                    "no" if hi < 1 - FLUX_TOL or lo > 1 + FLUX_TOL else "undecided")
    f = "yes" if flux == ["yes", "yes"] else "no" if "no" in flux else "undecided"
    b, e = s["blur_region"], s["blur_region_se"]
    rms = "yes" if b + 2 * e <= RMS_MAX else "no" if b - 2 * e > RMS_MAX else "undecided"
    return f, rms


def _pm(s, m) -> str:
    """'mean ± standard error' of measure ``m`` to 4 decimals."""
    e = s[m + "_se"]
    return f"{s[m]:.4f} ± " + ("< 0.0001" if e < 5e-5 else f"{e:.4f}")


def done_when_table(studies) -> str:
    """Markdown: per scene, k and search, the paper's estimate, the others and the default."""
    lines = ["| scene | k | search | estimate | flux / ref | flux / ref (region) | "
             "blurred rel. RMS (region) | same, seeds' mean image | regular grid: flux, RMS "
             "(region) | flux / splat | met: flux, RMS (2 std. errors) |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    default, paper = EstimateOptions().label, options()[0].label
    for st in studies:
        splat = {(r["k"], r["search"], r["option"]): r["flux_splat"] for r in st["rows"]
                 if r["seed"] not in (None, "mean")}
        for s in summary(st):
            name = ("**default**" if s["option"] == default else "paper" if s["option"] == paper
                    else f"`{s['option']}`")
            f, rms = verdict(s, st["reference"]["flux_rel_se_region"])
            fs = np.mean([v for key, v in splat.items() if key == (s["k"], s["search"], s["option"])])
            reg = s["regular"] or {m: math.nan for m in MEASURES}
            pooled = s["pooled"] or {m: math.nan for m in MEASURES}
            lines.append(
                f"| {s['scene']} | {s['k']} | {s['search']} | {name} | {_pm(s, 'flux')} | "
                f"{_pm(s, 'flux_region')} | {_pm(s, 'blur_region')} | {pooled['blur_region']:.4f} | "
                f"{reg['flux_region']:.3f}, {reg['blur_region']:.3f} | {fs:.3f} | "
                + (f"{f}, {rms}" if s["option"] == default else "") + " |")
    return "\n".join(lines)


def context_table(studies) -> str:
    """Markdown: per scene, what the rows rest on (photons, splat, reference noise, sampling)."""
    lines = ["| scene | photons stored (emitted) | splat / ref (region) | reference: photons, flux "
             "std. error (region) | pixels compared (region) | shading points | seeds |",
             "|---|---|---|---|---|---|---|"]
    for st in studies:
        ref = st["reference"]
        n = max((r.get("seeds", 0) or 0) for r in st["rows"])
        lines.append(f"| {st['scene']} | {st['photons']:,} ({st['emitted']:,}) | "
                     f"{st['splat']['flux']:.4f} ({st['splat']['flux_region']:.4f}) | "
                     f"{ref['photons']:,}, {ref['flux_rel_se_region']:.4f} | "
                     f"{ref['pixels_compared']:,} ({ref['pixels_region']:,}) | "
                     f"{st['samples']} x {st['samples']} jittered, {st['refine']} pixels again at "
                     f"{st['refine_samples']} x {st['refine_samples']} | {n} |")
    return "\n".join(lines)
