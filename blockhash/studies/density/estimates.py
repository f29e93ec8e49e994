"""The density estimate's options measured against the light-traced reference.

For each scene (Phong ``ks`` set to 0, so the receivers are Lambertian as the light
tracer's comparison assumes no glossy lobe is missing), photon count N and k, one photon
map is traced and its Block Hashing neighbours found once per pixel (the CPU reference
of the default shader variant: the same photons the caustic pass finds, or exact kNN
with cKDTree for the paper's and the default estimate, the lookup's own share); every
:class:`~blockhash.frame.estimate.EstimateOptions` is then evaluated on those same
neighbours, so the options differ only in the estimate.  Images are rendered at
``supersample`` times the size and box-filtered, as in the trade study.

Measures, per row (:mod:`blockhash.studies.measure`): ``flux`` the ratio of summed caustic radiance to the
reference's over the comparison mask (:meth:`LightTraceImage.comparison_mask`), ``blur``
the relative RMS after a 2-pixel Gaussian blur over that mask, and ``flux_region`` and
``blur_region`` the same over the *caustic region*: mask pixels whose blurred reference
exceeds :data:`REGION_FRACTION` of its 99th percentile.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from blockhash.evaluate.metrics import exact_knn
from blockhash.frame.caustic import Neighbours
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.gbuffer import rasterize
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.frame.shading_points import ShadingPoints
from blockhash.frame.subpixel import raycast_gbuffer
from blockhash.gl.lookup import query_slot_bits
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.reference.lighttrace import cached_reference, lambertian
from blockhash.scene.materials import receiver_materials
from blockhash.scene.model import MirrorMaterial
from blockhash.studies.command import count
from blockhash.studies.measure import flux_ratio, masked_blur, rel_rms
from blockhash.studies.tradeoff.sweep import box_down

#: The caustic region: blurred reference above this fraction of its 99th percentile.
REGION_FRACTION = 0.05


def default_options() -> list[EstimateOptions]:
    """The options every study compares: the paper's estimate, then one change at a time,
    the default (``EstimateOptions()``) among them."""
    O = EstimateOptions
    box = [O(estimate="paper", filter="none", normal_cos=None),
           O(estimate="unbiased", filter="none", normal_cos=None)]
    box += [O(estimate="unbiased", filter="none", normal_cos=c) for c in (0.0, 0.5, 0.9)]
    box += [O(estimate="unbiased", filter="none", normal_cos=0.5, disc=0.25)]
    filters = [O(estimate="unbiased", filter="cone", normal_cos=None)]
    filters += [O(estimate="unbiased", filter=f, normal_cos=0.5)
                for f in ("cone", "epanechnikov", "silverman")]
    conserving = [O(estimate="conserving", filter=f, normal_cos=0.5)
                  for f in ("none", "cone", "epanechnikov", "silverman")]
    return box + filters + conserving


def caustic_region(reference, mask) -> np.ndarray:
    """(h, w) bool: mask pixels where the blurred reference is above REGION_FRACTION of its p99."""
    b = masked_blur(reference, mask).sum(axis=2)
    top = float(np.percentile(b[mask], 99)) if mask.any() else 0.0
    return mask & (b > REGION_FRACTION * top)


#: Where the light-traced references are cached unless a command names another folder.
REFERENCE_CACHE = Path.home() / ".cache" / "blockhash"


def reference_options(parser, photons: int | None = None, *, flag: str = "--reference") -> None:
    """The options of a command that compares with the light-traced reference: ``--cache DIR``
    (default :data:`REFERENCE_CACHE`) and, given its default ``photons``, ``FLAG N`` (the
    light tracer's photons, a count such as 1e8)."""
    if photons is not None:
        parser.add_argument(flag, type=count, default=photons,
                            help=f"light-tracer photons shot for the reference (default {photons:.0e})")
    parser.add_argument("--cache", type=Path, default=REFERENCE_CACHE,
                        help=f"folder of the cached references (default {REFERENCE_CACHE})")


def lambertian_reference(scene, photons: int, *, size=None, cache_dir=REFERENCE_CACHE):
    """The reference a Lambertian render is compared with: ``(scene with every ks 0, its
    light-traced reference (cached), the comparison mask, the caustic region)``."""
    scene = lambertian(scene)
    ref, _ = cached_reference(scene, photons, size=size, cache_dir=cache_dir, progress=False)
    mask = ref.comparison_mask()
    return scene, ref, mask, caustic_region(ref.radiance, mask)


def measure(image, reference, mask, region) -> dict:
    return {"flux": flux_ratio(image, reference, mask),
            "blur": rel_rms(masked_blur(image, mask), masked_blur(reference, mask), mask),
            "flux_region": flux_ratio(image, reference, region),
            "blur_region": rel_rms(masked_blur(image, mask), masked_blur(reference, mask), region)}


def scene_points(scene, size, supersample: int, jitter: int | None = None, rays=None):
    """Shading points at ``supersample`` x ``supersample`` per pixel of ``size``: the
    rasterised regular grid (``jitter`` None, as the trade study) or stratified jitter
    with seed ``jitter`` (:mod:`blockhash.frame.subpixel`)."""
    ss = int(supersample)
    rays = SceneRays(scene.objects) if rays is None else rays
    if jitter is None:
        g = rasterize(scene.camera, scene.objects, size=(size[0] * ss, size[1] * ss))
    else:
        g = raycast_gbuffer(scene.camera, rays, size=size, samples=ss, seed=jitter)
    return shading_points(scene.camera, g, scene.objects, rays, (MirrorMaterial,))


def estimate_images(index, points, materials, search, k, options, *, only=None,
                    chunk: int = 1 << 15) -> list[np.ndarray]:
    """(h, w, 3) radiance of each of ``options`` from one ``search`` per shading point, in
    chunks of ``chunk`` points (the neighbours of 10^6 points at k = 50 take several GB at
    once).  ``only`` ((h, w) bool) limits the search to those points; the others stay 0."""
    h, w = points.shape
    live = points.material.reshape(-1) >= 0
    if only is not None:
        live &= np.asarray(only, bool).reshape(-1)
    idx = np.flatnonzero(live)
    flat = [a.reshape(h * w, *a.shape[2:]) for a in (points.position, points.normal, points.view,
                                                     points.material, points.weight)]
    outs = [np.zeros((h * w, 3)) for _ in options]
    for start in range(0, len(idx), chunk):
        sel = idx[start:start + chunk]
        nb = Neighbours.find(index, ShadingPoints(*(a[sel][None] for a in flat)), search, k,
                             own=options)
        for out, opt in zip(outs, options):
            out[sel] = nb.estimate(materials, opt)[0]
    return [o.reshape(h, w, 3) for o in outs]


def upsample(mask, s: int) -> np.ndarray:
    """(h, w) bool -> (h * s, w * s): each pixel's value on its s x s shading points."""
    return np.repeat(np.repeat(np.asarray(mask, bool), s, axis=0), s, axis=1)


def searches(index, k: int, A: int) -> dict:
    """``{'bh': the CPU reference of the default shader variant, 'exact': cKDTree}``."""
    bits = query_slot_bits(index.params, k, A)
    return {"bh": lambda q: index.reference_query(q, k=k, A=A, slot_bits=bits),
            "exact": lambda q: exact_knn(index.positions, q, k)}


def study_scene(scene, *, photons=(100_000, 1_000_000), ks=(50,), options=None, size=(128, 128),
                supersample: int = 2, jitter: int | None = None,
                reference_photons: int = 50_000_000, A: int = 8,
                cache_dir=None, progress=print) -> dict:
    """Rows of measures for one scene (module docstring); the reference's own noise beside
    them.  ``jitter``: None for the rasterised grid of shading points, else the seed of
    stratified jitter (:func:`scene_points`)."""
    options = default_options() if options is None else list(options)
    exact_options = [options[0], EstimateOptions()]
    scene = lambertian(scene)
    t0 = time.perf_counter()
    ref, path = cached_reference(scene, reference_photons, size=size, cache_dir=cache_dir)
    progress(f"{scene.path}: reference {ref!r} ({time.perf_counter() - t0:.0f} s)")
    mask = ref.comparison_mask()
    region = caustic_region(ref.radiance, mask)
    ss = int(supersample)
    points = scene_points(scene, size, ss, jitter)
    only = upsample(mask, ss)  # the measures read no other pixel
    materials = receiver_materials(scene.objects)
    rows = []
    for n in photons:
        pm = trace_caustic_photons(scene, n, seed=scene.photons.seed)
        for k in ks:
            index = BlockHashIndex(pm.positions, k=k, A=A, directions=pm.directions,
                                   normals=pm.normals, powers=pm.powers)
            find = searches(index, k, A)
            for search, opts in (("bh", options), ("exact", exact_options)):
                images = estimate_images(index, points, materials, find[search], k, opts, only=only)
                for opt, fine in zip(opts, images):
                    img = box_down(fine, ss)
                    row = {"scene": scene.path.stem if scene.path else "?", "photons": n, "k": k,
                           "search": search, "option": opt.label,
                           **measure(img, ref.radiance, mask, region)}
                    rows.append(row)
                    progress(f"  N={n:,} k={k} {search:5s} {opt.label:28s} flux {row['flux']:.4f} "
                             f"blur {row['blur']:.4f} | region flux {row['flux_region']:.4f} blur "
                             f"{row['blur_region']:.4f}")
    # the reference's own noise: its standard error blurred like the images (independent pixels)
    se = ref.stderr
    noise = float(np.sqrt(np.mean(se[region] ** 2)) / np.sqrt(np.mean(ref.radiance[region] ** 2)))
    return {"scene": scene.path.name if scene.path else None, "size": list(size), "supersample": ss,
            "jitter": jitter,
            "reference": {"photons": ref.emitted, "cache": str(path) if path else None,
                          "pixels_compared": int(mask.sum()), "pixels_region": int(region.sum()),
                          "rel_noise_region": noise},
            "rows": rows}


def markdown_table(studies) -> str:
    """One table of every row of every study."""
    lines = ["| scene | N | k | search | option | flux / ref | blurred rel. RMS | flux / ref (region) | "
             "blurred rel. RMS (region) |", "|---|---|---|---|---|---|---|---|---|"]
    for s in studies:
        for r in s["rows"]:
            lines.append(f"| {r['scene']} | {r['photons']:,} | {r['k']} | {r['search']} | "
                         f"`{r['option']}` | "
                         f"{r['flux']:.4f} | {r['blur']:.4f} | {r['flux_region']:.4f} | "
                         f"{r['blur_region']:.4f} |")
    return "\n".join(lines)


def summary_table(studies) -> str:
    """Per scene, N and k: the paper's estimate against the default, over the whole compared
    area (flux, blurred relative RMS) and the caustic region (same), BH and exact kNN."""
    paper = default_options()[0].label
    default = EstimateOptions().label
    lines = ["| scene | N | k | estimate | search | flux / ref | blurred rel. RMS | "
             "flux / ref (region) | blurred rel. RMS (region) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for s in studies:
        for r in s["rows"]:
            if r["option"] in (paper, default):
                name = "paper" if r["option"] == paper else "**default**"
                lines.append(f"| {r['scene']} | {r['photons']:,} | {r['k']} | {name} `{r['option']}` | "
                             f"{r['search']} | {r['flux']:.3f} | {r['blur']:.3f} | "
                             f"{r['flux_region']:.3f} | {r['blur_region']:.3f} |")
    return "\n".join(lines)


def option_table(studies, k: int = 50, *, region: bool = False) -> str:
    """Options as rows, (scene, N) as columns, "flux / blurred rel. RMS" at one k (BH)."""
    rows = [r for st in studies for r in st["rows"] if r["k"] == k and r["search"] == "bh"]
    cols = list(dict.fromkeys((r["scene"], r["photons"]) for r in rows))
    opts = list(dict.fromkeys(r["option"] for r in rows))
    cell = {(r["scene"], r["photons"], r["option"]): r for r in rows}
    f, b = ("flux_region", "blur_region") if region else ("flux", "blur")
    lines = [f"| option (k = {k}, BH) | " + " | ".join(f"{s} N={n:,}" for s, n in cols) + " |",
             "|---|" + "---|" * len(cols)]
    for o in opts:
        vals = [cell.get((s, n, o)) for s, n in cols]
        lines.append(f"| `{o}` | " + " | ".join("" if v is None else f"{v[f]:.3f} / {v[b]:.3f}"
                                                for v in vals) + " |")
    return "\n".join(lines)
