"""Shader benchmark: Block Hashing variants against exact kNN, in one run (paper section 6).

For one photon map and one query set it times, side by side: each BH shader
variant at each A, the fetch-only shader (same candidate texels, no selection:
the memory floor; it fetches every candidate, so a variant that culls blocks can
run below it), the exact kd-tree shader when available, and scipy's cKDTree
on the CPU with all workers.  Optionally (``caustic_scene``) it also times the
stages of a scene's caustic pass.

GL figures are taken the way GPU work is timed: per program, ``warmup`` draws of
the very program that is then timed, then ``repeat`` back-to-back draws with no
read-back between them, each inside a GL timer query (GPU time) and with the
pipeline drained after it (wall time); min and median are reported.  The query
count and width are uniforms, so the warm-up compiles exactly what is timed.
Rows compare by ``seconds``, the median on the run's clock: GPU time where the
timer query covers the draw, wall time on Mesa's llvmpipe, whose timer query
covers only part of the draw (measured: 8 ms against 52 ms wall for one draw).
Every row carries the GL renderer and version.  Recall is measured against the
exact neighbours, outside the timing.
"""

from __future__ import annotations

import copy
import json
import os
import statistics
import time
from dataclasses import replace

import numpy as np

from blockhash.evaluate.datasets import DISTRIBUTIONS
from blockhash.evaluate.metrics import exact_knn, false_negatives
from blockhash.index.block_hash_index import BlockHashIndex

QUERY_SETS = ("image", "random")
CLOCKS = ("auto", "gpu", "wall")


def make_queries(pts: np.ndarray, m: int, kind: str, seed: int, data: str) -> np.ndarray:
    """(m, 3) float32 query points.

    ``image``: a raster of pixels over the receiver seen from above, row by row,
    as a caustic pass visits them: the plane y = median(y) across the 1-99%
    x and z range of the photons (neighbouring queries are neighbouring points).
    ``random``: fresh samples of the photon distribution, in random order
    (no coherence between neighbouring queries).
    """
    if kind == "random":
        return DISTRIBUTIONS[data](m, np.random.default_rng(seed)).astype(np.float32)
    side = int(np.ceil(np.sqrt(m)))
    lo, hi = np.percentile(pts[:, [0, 2]], [1, 99], axis=0)
    xs = np.linspace(lo[0], hi[0], side)
    zs = np.linspace(lo[1], hi[1], side)
    gz, gx = np.meshgrid(zs, xs, indexing="ij")
    q = np.stack([gx.ravel(), np.full(gx.size, np.median(pts[:, 1])), gz.ravel()], axis=1)
    return q[:m].astype(np.float32)


def device_info(ctx) -> dict:
    """The GL renderer, vendor, version and backend, and the CPU count, for every result."""
    from blockhash.gl.context import gl_info

    info = gl_info(ctx)
    return {"renderer": info["renderer"], "vendor": info["vendor"], "gl_version": info["version"],
            "backend": info["backend"], "cpus": os.cpu_count()}


def resolve_clock(clock: str, renderer: str) -> str:
    """'gpu' or 'wall' for ``clock`` in CLOCKS; 'auto' is wall time on llvmpipe only."""
    if clock not in CLOCKS:
        from blockhash.errors import InputError

        raise InputError(f"clock={clock!r} is not known; choose one of {', '.join(CLOCKS)}")
    if clock == "auto":
        return "wall" if "llvmpipe" in (renderer or "") else "gpu"
    return clock


def summarize(times: dict, clock: str) -> dict:
    """Min and median of {'wall': [...], 'gpu': [...]} seconds, and ``seconds`` on ``clock``."""
    out = {"draws": len(times["wall"])}
    for name, values in times.items():
        if any(v != v for v in values):  # NaN: a saturated GL timer query (> 4.29 s)
            out[f"{name}_min"] = out[f"{name}_median"] = None
            continue
        out[f"{name}_min"] = min(values)
        out[f"{name}_median"] = statistics.median(values)
    if out.get(f"{clock}_median") is None:
        clock = "wall"
    out["clock"] = clock
    out["seconds"] = out[f"{clock}_median"]
    return out


#: Queries the CPU reference runs to count a lookup's rounds of dependent fetches.
ROUNDS_SAMPLE = 4096


def run_benchmark(*, photons=1_000_000, queries=512 * 512, k=50, A_values=(1, 2, 4, 8, 16),
                  variants=("default",), data="caustic", repeat=10, warmup=2, backend=None, seed=0,
                  kdtree=True, query_set="image", clock="auto", hashing=False, progress=print):
    """Run the benchmark and return a list of result rows (dicts).  ``hashing``: also time
    each variant on the same index's Hilbert cells (``cells=True``) and with the walk off
    (the tables hashed and probed, ``best_first=False``), beside the default, each with its
    own fetch-only floor."""
    from scipy.spatial import cKDTree

    from blockhash.gl.lookup import GLLookup

    pts = DISTRIBUTIONS[data](photons, np.random.default_rng(seed))
    q = make_queries(pts, queries, query_set, seed + 1, data)
    index = BlockHashIndex(pts, k=k, A=max(A_values))
    positions = index.positions.astype(np.float64)
    lookup = GLLookup(index, backend=backend)
    lookups = [("", lookup)]
    if hashing and not index.params.cells:
        celled = copy.copy(index)
        celled.params = replace(index.params, cells=True)
        lookups.append((" (Hilbert cells)", GLLookup(celled, backend=backend)))
    if hashing and index.params.best_first:
        hashed = copy.copy(index)
        hashed.params = replace(index.params, best_first=False, cells=False)
        lookups.append((" (tables hashed, walk off)", GLLookup(hashed, backend=backend)))
    device = device_info(lookup.ctx)
    clk = resolve_clock(clock, device["renderer"])
    progress(f"{device['renderer']} ({device['gl_version']}); clock: {clk}")
    progress(f"photons {photons:,} ({data}), queries {queries:,} ({query_set}), k={k}; "
             f"{index.params!r}")
    # An image raster is drawn at its own width, so neighbouring fragments are neighbouring
    # pixels, as in a caustic pass; a random set keeps the lookup's default width.
    width = int(np.ceil(np.sqrt(queries))) if query_set == "image" else None
    exact = exact_knn(positions, q, k)
    tree = cKDTree(positions)
    q64 = q.astype(np.float64)
    tree.query(q64[:64], k=k, workers=-1)
    walls = []
    for _ in range(repeat):
        t = time.perf_counter()
        tree.query(q64, k=k, workers=-1)
        walls.append(time.perf_counter() - t)
    ckd = {"draws": repeat, "wall_min": min(walls), "wall_median": statistics.median(walls),
           "clock": "wall", "seconds": statistics.median(walls)}
    rows = [{"method": "cKDTree (CPU, all workers)", "A": None, **ckd, "fn_percent": 0.0, **device}]
    progress(f"cKDTree: {rows[0]['seconds']:.3f} s")
    rounds = {}
    for A in A_values:
        runs = [(f"BH {v}{tag}", lk, {"variant": v}) for tag, lk in lookups for v in variants]
        floors = [(f"BH fetch-only floor{tag}", lk, {"fetch_only": True}) for tag, lk in lookups]
        for name, lk, kwargs in runs + floors:
            times = lk.time_draws(q, k, A=A, repeat=repeat, warmup=warmup, width=width, **kwargs)
            row = {"method": name, "A": A, **summarize(times, clk), **device}
            _, idx = lk.query(q, k=k, A=A, width=width, **kwargs)
            row["candidates"] = lk.counters["query.candidates.mean"]
            row["blocks_culled"] = lk.counters["query.blocks_culled.mean"]
            if not kwargs.get("fetch_only"):
                row["fn_percent"] = 100.0 * false_negatives(idx, exact[1], len(index)).mean() / k
                # Rounds of dependent fetches, from the CPU reference of the same lookup
                # (the variants of one lookup share them).
                if (id(lk), A) not in rounds:
                    lk.index.query(q[:ROUNDS_SAMPLE], k, A=A)
                    rounds[id(lk), A] = (lk.index.counters.get("query.rounds.mean"),
                                         lk.index.counters.get("query.rounds.max"))
                row["rounds_mean"], row["rounds_max"] = rounds[id(lk), A]
            rows.append(row)
            progress(f"{name} A={A}: {row['seconds']:.4f} s")
    if kdtree:
        rows.append(_kdtree_row(index, q, k, repeat, warmup, backend, clk, device))
        progress(f"kd-tree shader: {rows[-1]['seconds']:.4f} s")
    rows.append(_cover_row(index, q, k, repeat, warmup, backend, clk, device))
    progress(f"cover gather: {rows[-1]['seconds']:.4f} s")
    return rows


def _cover_row(index, q, k, repeat, warmup, backend, clock, device) -> dict:
    """The cover gather alone (the caustic pass's lookup stage: every photon whose own disc
    covers each point, counted, no estimate) on the same queries, as one image of shading
    points facing +y; its radii (for k) are computed outside the timing."""
    from blockhash.frame.caustic import STAGES, CausticPass
    from blockhash.frame.cover_estimate import cover_gather
    from blockhash.frame.shading_points import ShadingPoints

    m = len(q)
    side = int(np.ceil(np.sqrt(m)))
    rows_ = -(-m // side)
    pos = np.zeros((rows_ * side, 3), np.float32)
    pos[:m] = q
    mat = np.full(rows_ * side, -1, np.int32)
    mat[:m] = 0
    up = np.tile(np.float32([0, 1, 0]), (rows_, side, 1))
    points = ShadingPoints(position=pos.reshape(rows_, side, 3), normal=up, view=up,
                           material=mat.reshape(rows_, side), weight=np.ones_like(up))
    gather = cover_gather(index, k)
    cov = gather.query(q)
    times = CausticPass(index, backend=backend, gather="cover").time_stages(
        points, [((0.5,) * 3, (0.0,) * 3, 1.0)], k=k, repeat=repeat, warmup=warmup,
        stages=(STAGES[1],))[STAGES[1]]
    return {"method": "cover gather (alone)", "A": None, **summarize(times, clock),
            "covering_mean": float(cov.counts.mean()), "candidates": float(cov.candidates.mean()),
            **device}


def _kdtree_row(index, q, k, repeat, warmup, backend, clock, device) -> dict:
    """The exact kd-tree shader on the same queries: its program (one per k and tree) is
    warmed up by whole queries, then each timed query sums its passes' draws."""
    from blockhash.gl.kdtree import GLKdTree

    kd = GLKdTree(index.positions, backend=backend)
    times = {"wall": [], "gpu": []}
    for i in range(warmup + repeat):
        kd.query(q, k)
        if i >= warmup:
            times["wall"].append(kd.counters["gl.draw_seconds"])
            times["gpu"].append(kd.counters["gl.gpu_seconds"])
    return {"method": "kd-tree shader (exact)", "A": None, **summarize(times, clock),
            "fn_percent": 0.0, "passes": kd.counters["query.passes"], **device}


#: The caustic pass's peers that ``run_caustic_benchmark`` times side by side: the cover
#: gather (the default), the k-nearest walk and cells lookups, the exact kd-tree shader, the
#: CPU reference of the default, and photon splatting (the default's estimate scattered).
PEERS = ("cover", "walk", "cells", "kdtree", "cpu", "splat")


def run_caustic_benchmark(scene_path, *, photons=None, A=None, variant="default", repeat=10,
                          warmup=2, backend=None, clock="auto", estimates=(), gathers=PEERS,
                          progress=print):
    """Time a scene's caustic pass on its own pixels, one peer of ``gathers`` after another
    (:data:`PEERS`): the shader gathers per stage (blockhash.frame.caustic.STAGES), the
    kd-tree, CPU and splatting methods whole; then the walk's whole pass once more with each
    of ``estimates`` (forms of :class:`~blockhash.frame.estimate.EstimateOptions`, the other
    fields the default's).  Each row names its ``gather`` and ``stage``, with ``seconds``; the
    splatting row also its ``reach``, the share of the cover gather's caustic (summed over the
    pixels) that it reaches: splatting misses what the camera sees in mirrors and glass."""
    from blockhash.frame.caustic import STAGES, CausticPass, estimate_exact
    from blockhash.frame.cover_estimate import cover_gather, estimate_cover_cpu
    from blockhash.frame.estimate import EstimateOptions
    from blockhash.frame.gbuffer import rasterize
    from blockhash.frame.photon_radius import exact_radii2, own_radii2
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.frame.shading import shading_points
    from blockhash.gl.context import get_context
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.scene.loader import load_scene
    from blockhash.scene.materials import receiver_materials
    from blockhash.scene.model import MirrorMaterial

    forms = [EstimateOptions(estimate=form) for form in estimates]  # unknown names fail first
    unknown = [g for g in gathers if g not in PEERS]
    if unknown:
        from blockhash.errors import InputError

        raise InputError(f"gathers {unknown} are not known; choose from {', '.join(PEERS)}")
    scene = load_scene(scene_path)
    settings = scene.photons
    pm = trace_caustic_photons(scene, photons or settings.count, seed=settings.seed)
    index = BlockHashIndex(pm.positions, k=settings.k, A=A or settings.A, directions=pm.directions,
                           normals=pm.normals, powers=pm.powers)
    gbuf = rasterize(scene.camera, scene.objects, backend=backend)
    points = shading_points(scene.camera, gbuf, scene.objects, SceneRays(scene.objects),
                            (MirrorMaterial,))
    materials = receiver_materials(scene.objects)
    own_radii2(index, settings.k)  # computed once, outside the timing
    h, w = points.shape
    live = int((points.material >= 0).sum())
    base = {"A": A or settings.A, "scene": str(scene_path), "photons": len(index), "pixels": w * h}
    rows = []

    def add(gather, stage, times, device, clk):
        rows.append({"method": f"caustic pass ({gather}): {stage}", "gather": gather,
                     "stage": stage, **base, **summarize(times, clk), **device})
        progress(f"caustic pass ({gather}) {stage}: {rows[-1]['seconds']:.4f} s")

    device = clk = None
    for gather in gathers:
        if gather in ("cover", "walk", "cells"):
            ix = index
            if gather == "cells":
                ix = copy.copy(index)
                ix.params = replace(index.params, cells=True)
            cp = CausticPass(ix, backend=backend, gather="cover" if gather == "cover" else "knn")
            if device is None:
                device = device_info(cp.ctx)
                clk = resolve_clock(clock, device["renderer"])
                progress(f"caustic pass of {scene_path}: {len(index):,} photons stored, {w} x {h} "
                         f"pixels ({live:,} shaded), k={settings.k}, A={A or settings.A}; "
                         f"{device['renderer']}")
            stages = cp.time_stages(points, materials, A=A, variant=variant, repeat=repeat,
                                    warmup=warmup)
            if gather == "walk":
                for opt in forms:
                    timed = cp.time_stages(points, materials, A=A, variant=variant, repeat=repeat,
                                           warmup=warmup, options=opt, stages=STAGES[-1:])
                    stages[f"{STAGES[-1]} ({opt.estimate})"] = timed[STAGES[-1]]
            for stage, times in stages.items():
                add(gather, stage, times, device, clk)
            continue
        if gather == "splat":
            from blockhash.studies.shaders.splat_pass import SplatPass

            gathered = cover_gather(index, settings.k)
            image, walls = SplatPass(gathered, backend=backend).render(
                points, materials, scene.camera, repeat=warmup + repeat)
            cover = CausticPass(index, backend=backend, gather="cover").render(points, materials)
            add(gather, STAGES[-1], {"wall": walls[warmup:]}, device or device_info(get_context(backend)),
                "wall")
            rows[-1]["reach"] = float(image.sum() / max(float(cover.sum()), 1e-300))
            progress(f"splatting reaches {rows[-1]['reach']:.1%} of the gathered caustic")
            continue
        if gather == "kdtree":
            exact_radii2(index, settings.k)

            def run():
                return estimate_exact(index, points, materials, backend=backend)
        else:
            gathered = cover_gather(index, settings.k)

            def run():
                return estimate_cover_cpu(gathered, points, materials)
        walls = []
        for i in range(warmup + repeat):
            t = time.perf_counter()
            run()
            if i >= warmup:
                walls.append(time.perf_counter() - t)
        dev = device or device_info(get_context(backend))
        add(gather, STAGES[-1], {"wall": walls}, dev, "wall")
    return rows


def format_table(rows, queries) -> str:
    by = {(r["method"], r["A"]): r for r in rows}
    ckd = by.get(("cKDTree (CPU, all workers)", None), {}).get("seconds")
    kd = by.get(("kd-tree shader (exact)", None), {}).get("seconds")
    first = rows[0]
    lines = [f"{first['renderer']} | {first['gl_version']} | backend {first['backend']} | "
             f"{first['cpus']} CPUs",
             f"{'method':<34} {'A':>3} {'median ms':>10} {'min ms':>8} {'GPU med':>8} {'wall med':>8} "
             f"{'queries/s':>12} {'/cKDTree':>9} {'/kd-tree':>9} {'/floor':>7} {'FN %k':>6} "
             f"{'rounds':>11}"]
    for r in rows:
        floor = by.get(("BH fetch-only floor", r["A"]), {}).get("seconds")
        clock_min = r[f"{r.get('clock', 'wall')}_min"]
        n = r.get("pixels", queries)
        cells = [f"{r['method']:<34}", f"{'' if r['A'] is None else r['A']:>3}",
                 f"{1e3 * r['seconds']:>10.2f}", f"{1e3 * clock_min:>8.2f}",
                 f"{1e3 * r['gpu_median']:>8.2f}" if r.get("gpu_median") else f"{'-':>8}",
                 f"{1e3 * r['wall_median']:>8.2f}",
                 f"{n / r['seconds']:>12,.0f}",
                 f"{r['seconds'] / ckd:>9.2f}" if ckd and "pixels" not in r else f"{'-':>9}",
                 f"{r['seconds'] / kd:>9.2f}" if kd and "pixels" not in r else f"{'-':>9}",
                 f"{r['seconds'] / floor:>7.2f}" if floor and r["A"] and "pixels" not in r else f"{'-':>7}",
                 f"{r['fn_percent']:>6.1f}" if "fn_percent" in r else f"{'-':>6}",
                 f"{r['rounds_mean']:>6.1f}/{r['rounds_max']:<4.0f}" if r.get("rounds_mean")
                 else f"{'-':>11}"]
        lines.append(" ".join(cells))
    return "\n".join(lines)


def write_results(rows, path: str) -> None:
    """JSON for plots: a list of rows, one per method and A, each with the device."""
    with open(path, "w") as fh:
        json.dump(rows, fh, indent=1)
