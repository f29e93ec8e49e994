"""The accuracy runs of the index on named photon maps, synthetic or traced from the scenes,
beside the exact k nearest (cKDTree): what ``tools/eval_accuracy.py``, ``tools/accuracy_by_k.py``,
``tools/small_k.py`` and ``tools/cell_cover_bound.py`` run and tabulate.  :data:`TUNE` are the
maps the default preset's constants were chosen on, :data:`REPORT` the maps none was.
:func:`run_options` are the options those tools share, :func:`save_rows` their ``--json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import blockhash.index.tables.params as bp
from blockhash.errors import InputError
from blockhash.evaluate.metrics import accuracy, exact_knn, false_negatives, far_queries
from blockhash.evaluate.photon_maps import PhotonMap, named, queries
from blockhash.index.block_hash_index import BlockHashIndex, OrphanWarning
from blockhash.index.lookups.cell_cover import cover_bound, level_counts
from blockhash.index.lookups.cells import LEVEL_MIN, LEVEL_TOP
from blockhash.index.records.fixedpoint import Quantizer
from blockhash.studies.command import count, listing, write_json

#: Maps the default preset's constants were chosen on.
TUNE = ("uniform", "clustered", "caustic", "ring")
#: Maps no constant was chosen on.
REPORT = ("plane", "tilted", "room", "sphere", "venus", "tilted@1e4", "roomx0.001")
PRESETS = ("default", "paper")
#: The maps traced from the checkout's scenes (:func:`scene_map`).
SCENE_MAPS = ("ring", "venus")


def map_name(text: str) -> str:
    """A photon map's name (:func:`photon_map`), for a tool's ``--maps``."""
    if text not in SCENE_MAPS:
        try:
            named(text)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def run_options(parser, *, maps=TUNE + REPORT, photons=100_000, queries=4000, k=50,
                A=(8, 64)) -> None:
    """``--maps``, ``--photons``, ``--queries``, ``--k`` and ``--A`` on a tool's
    :class:`~blockhash.studies.command.ToolParser`: ``--k`` and ``--A`` take comma-separated
    lists where their defaults are lists, one count otherwise."""
    parser.add_argument("--maps", type=listing(map_name), default=list(maps),
                        help=f"photon maps (default {','.join(maps)})")
    parser.photons(photons, help="photons per map")
    parser.add_argument("--queries", type=count, default=queries,
                        help=f"queries per map (default {queries:,})")
    for flag, default, what in (("--k", k, "neighbours k"), ("--A", A, "the accuracy knob A")):
        many = isinstance(default, (list, tuple))
        parser.add_argument(flag, type=listing(count) if many else count,
                            default=list(default) if many else default,
                            help=f"{what} (default "
                            f"{','.join(map(str, default)) if many else default})")


def one_of(*names: str):
    """The type of a comma-separated list of ``names`` (for ``--lookups``, ``--presets``)."""
    def parse(text: str) -> str:
        if text not in names:
            raise argparse.ArgumentTypeError(f"{text!r}: expected one of {', '.join(names)}")
        return text
    parse.__name__ = "name"
    return listing(parse)


def rows_options(parser, what="the rows") -> None:
    """``--json PATH`` (the run's rows) and ``--from-json FILE`` (the tables of a saved run,
    :func:`saved_rows`, instead of running)."""
    parser.json_output(f"write {what} here")
    parser.add_argument("--from-json", type=Path, metavar="FILE",
                        help="print the tables of a saved run (--json) instead of running")


def saved_rows(path) -> list[dict]:
    """The rows of a run saved with :func:`save_rows`."""
    return json.loads(Path(path).read_text())["rows"]


def save_rows(path, tool_file: str, argv, rows: list[dict], **extra) -> None:
    """A run's rows as JSON at ``path``, with the command that made them (``argv``: the
    tool's arguments, ``None`` for the command line's) and ``extra`` fields."""
    args = sys.argv[1:] if argv is None else list(argv)
    command = " ".join([f"python tools/{Path(tool_file).name}", *map(str, args)])
    write_json(path, {"command": command, **extra, "rows": rows})


def scene_map(name: str, scenes: Path) -> PhotonMap:
    """The photon map that ``scenes/NAME.toml`` traces, with shading points uniform over its
    diffuse (non-mirror) surfaces by area, where they lie inside the box of the map's photons
    (grown by a tenth of its diagonal): the scenes' floors and the bust extend far beyond the
    caustic, and a shading point metres from every photon has no caustic to estimate (its k
    nearest photons are found at about their distance, with dilation near 1, but rarely the
    same ones)."""
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.scene.loader import load_scene

    scene = load_scene(Path(scenes) / f"{name}.toml")
    diffuse = [o.mesh for o in scene.objects if not o.is_specular]
    tri = np.concatenate([m.vertices[m.faces] for m in diffuse])
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)

    def photons(n, rng):
        seed = int(rng.integers(0, 2**31))
        return trace_caustic_photons(scene, n, seed=seed).positions

    box = photons(20_000, np.random.default_rng(12345))
    lo, hi = box.min(axis=0), box.max(axis=0)
    grow = 0.1 * np.linalg.norm(hi - lo)
    lo, hi = lo - grow, hi + grow

    def surfaces(n, rng):
        out = np.empty((0, 3))
        while len(out) < n:
            f = rng.choice(len(tri), size=4 * n, p=area / area.sum())
            u, v = rng.random((2, 4 * n))
            flip = u + v > 1
            u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
            t = tri[f]
            p = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
            out = np.concatenate([out, p[np.all((p >= lo) & (p <= hi), axis=1)]])
        return out[:n]

    return PhotonMap(name, photons, surfaces)


def photon_map(name: str, scenes: Path) -> PhotonMap:
    """The synthetic map ``name`` (:mod:`.photon_maps`), or the traced one of the scenes
    ``ring`` and ``venus`` under the folder ``scenes`` (:func:`scene_map`)."""
    return scene_map(name, scenes) if name in SCENE_MAPS else named(name)


def warm_up() -> None:
    """Compile numba's build and query paths on a tiny input, so that no timed build pays
    for them."""
    BlockHashIndex(named("uniform").photons(5000, np.random.default_rng(9)), k=8,
                   A=2).query(np.zeros((4, 3)))


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def evaluate(name: str, n: int, m: int, k: int, As, presets, configs=({},), lookup=None, *,
             scenes: Path) -> list[dict]:
    """Rows of the index's accuracy on the map ``name`` (:func:`photon_map`): ``n`` photons,
    ``m`` queries, each preset and A (the default preset with each of ``configs``, its
    constants overridden), beside the exact k nearest."""
    pm = photon_map(name, scenes)
    pts = pm.photons(n, np.random.default_rng(0))
    q = queries(pm, m, np.random.default_rng(1))
    t_kd, _ = timed(lambda: cKDTree(pts))
    rows = []
    exact = None
    shipped = bp.adaptive_params
    for preset, A, config in [(p, A, c) for p in presets for c in (configs if p == "default" else ({},))
                              for A in As]:
            tuned = {key: v for key, v in config.items() if key != "layout"}
            chosen = {key: v for key, v in config.items() if key == "layout"}
            bp.adaptive_params = lambda positions, k, A, c=tuned: shipped(positions, k=k, A=A, **c)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", OrphanWarning)
                t_build, index = timed(lambda: BlockHashIndex(pts, k=k, A=A, preset=preset, **chosen))
            bp.adaptive_params = shipped
            if exact is None:
                # The float32 query the index sees (10^4 m from the origin, float32 rounds
                # a coordinate by up to 0.5 mm): quantization is not the index's error.
                exact = exact_knn(index.positions, q.astype(np.float32), k)
            t_query, found = timed(lambda: index.query(q, lookup=lookup))
            rounds = index.counters.get("query.rounds.mean", float("nan"))
            rounds_max = index.counters.get("query.rounds.max", float("nan"))
            half = m // 2
            acc = accuracy(found, exact, n)
            on = accuracy((found[0][:half], found[1][:half]), (exact[0][:half], exact[1][:half]), n)
            off = accuracy((found[0][half:], found[1][half:]), (exact[0][half:], exact[1][half:]), n)
            far = far_queries(exact[0])
            fn = false_negatives(found[1], exact[1], n)
            s = index.stats
            rows.append({
                "map": name, "set": "tune" if name in TUNE else "report", "preset": preset,
                "config": config,
                "photons": n, "queries": m, "k": k, "A": A,
                "fn_mean": acc.fn_fraction, "fn_p90": acc.false_negatives["p90"] / k,
                "fn_on": on.fn_fraction, "fn_off": off.fn_fraction,
                "far_share": float(far.mean()),
                "fn_near": float(fn[~far].mean() / k) if (~far).any() else 0.0,
                "fn_far": float(fn[far].mean() / k) if far.any() else 0.0,
                "avg_dilation": acc.avg_dilation["mean"], "max_dilation": acc.max_dilation["mean"],
                "candidates": index.counters["query.candidates.mean"], "rounds": rounds,
                "rounds_max": rounds_max, "blocks": index.counters["query.blocks.mean"],
                "lookup": lookup or "preset",
                "pops": index.counters.get("query.pops.mean", 0.0),
                "query_seconds": t_query, "build_seconds": t_build, "ckdtree_build_seconds": t_kd,
                "refs_per_photon": s.refs_per_photon,
                "bytes_per_photon": (s.index_bytes + s.block_bytes) / n,
                "orphans": s.orphans, "params": repr(s.params),
            })
            r = rows[-1]
            print(f"{name:12s} {preset:7s} {config or ''} A={A:<3d} fn {100 * r['fn_mean']:5.2f}% "
                  f"(p90 {100 * r['fn_p90']:5.1f}%, on {100 * r['fn_on']:5.2f}%, off "
                  f"{100 * r['fn_off']:5.2f}%; near {100 * r['fn_near']:5.2f}%, far "
                  f"{100 * r['fn_far']:5.2f}% of {100 * r['far_share']:.0f}%)  dil {r['avg_dilation']:.3f}/{r['max_dilation']:.3f}  "
                  f"cand {r['candidates']:6.0f}  blocks {r['blocks']:5.1f}  rounds {r['rounds']:5.1f}/{r['rounds_max']:.0f}  refs/ph {r['refs_per_photon']:.2f}  build "
                  f"{t_build:.2f}s ({t_build / t_kd:.1f}x cKDTree)  orphans {s.orphans}", flush=True)
    return rows




def build_beside_ckdtree(pts: np.ndarray, k: int, A: int, repeat: int) -> dict:
    """The index's build (default preset) and cKDTree's of the same photons, one right after
    the other, ``repeat`` times: median seconds of each, their ratio, and the median of each
    of the build's stages (the index's own timings)."""
    bh, kd, stages = [], [], []
    for _ in range(repeat):
        t_bh, index = timed(lambda: BlockHashIndex(pts, k=k, A=A))
        t_kd, _ = timed(lambda: cKDTree(pts))
        bh.append(t_bh)
        kd.append(t_kd)
        stages.append(index.timings)
    return {"photons": len(pts), "k": k, "A": A, "build_s": float(np.median(bh)),
            "ckdtree_s": float(np.median(kd)), "ratio": float(np.median(bh) / np.median(kd)),
            "stages": {s: float(np.median([t[s] for t in stages]))
                       for s in ("encode", "blocks", "thresholds", "insert", "pack")}}


def plane_false_negatives(positions: np.ndarray, k: int, A: int, preset: str, dys,
                          m: int) -> list[float]:
    """False negatives (share of k) of an index (``preset``) over photons on a plane y = 0,
    queried at the first ``m`` photons' x and z moved 1 mm sideways, at each height of
    ``dys``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        index = BlockHashIndex(positions, k=k, A=A, preset=preset)
    out = []
    for dy in dys:
        q = positions[:m] * [1.0, 0.0, 1.0] + [1e-3, dy, 0.0]
        out.append(accuracy(index.query(q), exact_knn(index.positions, q, k), len(index)).fn_fraction)
    return out


def walk_floor_rows(name: str, n: int, m: int, ks, A: int, floors, tables, *,
                    scenes: Path) -> list[dict]:
    """The walk at small k on the map ``name``: per floor (``BlockHashParams.walk_floor``)
    and tables walked below it, the false negatives (share of k, CPU reference) at each k."""
    pm = photon_map(name, scenes)
    pts = pm.photons(n, np.random.default_rng(0))
    q = queries(pm, m, np.random.default_rng(1)).astype(np.float32)
    indexes = {k: BlockHashIndex(pts, k=k, A=A) for k in ks}
    exact = {k: exact_knn(indexes[k].positions, q, k) for k in ks}
    rows = []
    for floor in floors:
        for walked in tables:
            fn = {}
            for k in ks:
                ix = indexes[k]
                ix.params = replace(ix.params, walk_floor=floor)
                _, idx = ix.reference_query(q, k=k, walk_trees=walked if k < floor else None)
                fn[k] = float(false_negatives(np.asarray(idx).reshape(len(q), -1), exact[k][1],
                                              len(pts)).mean() / k)
            rows.append({"map": name, "photons": n, "queries": m, "A": A, "floor": floor,
                         "tables": walked, "fn": fn})
    return rows


def cell_cover_rows(name: str, n: int, m: int, k: int, As, cells, *, scenes: Path) -> list[dict]:
    """The least a lookup of at most ``cells`` whole cells of one level must read to be
    exact (:func:`~blockhash.index.lookups.cell_cover.cover_bound`) on the map ``name``:
    per cell count and A, the share of near and far queries whose bound exceeds A k."""
    pm = photon_map(name, scenes)
    pts = pm.photons(n, np.random.default_rng(0))
    q = queries(pm, m, np.random.default_rng(1)).astype(np.float32)
    # The index's fixed point (its cells are octree cells of these codes) and the positions
    # it decodes; no tables are needed.
    quantizer = Quantizer.for_points(pts)
    codes = quantizer.encode(pts)
    d, _ = exact_knn(quantizer.decode(codes), q, k)
    far = far_queries(d)
    step = float(quantizer.step[0])
    q_codes = (q.astype(np.float64) - quantizer.lo.astype(np.float64)) / step
    r_codes = d[:, -1] / step
    tables = {lv: level_counts(codes, lv) for lv in range(LEVEL_MIN, LEVEL_TOP + 1)}
    rows = []
    for c in cells:
        bound = cover_bound(q_codes, r_codes, tables, c)
        for A in As:
            over = bound > A * k
            rows.append({"map": name, "set": "tune" if name in TUNE else "report", "photons": n,
                         "queries": m, "k": k, "A": A, "cells": c,
                         "far_share": float(far.mean()),
                         "over_near": float(over[~far].mean()) if (~far).any() else 0.0,
                         "over_far": float(over[far].mean()) if far.any() else 0.0,
                         "median_bound_far": float(np.median(bound[far])) if far.any() else 0.0})
    return rows
