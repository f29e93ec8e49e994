"""The accuracy runs of the index on named photon maps, synthetic or traced from the scenes,
beside the exact k nearest (cKDTree): what ``tools/eval_accuracy.py``, ``tools/accuracy_by_k.py``,
``tools/small_k.py`` and ``tools/cell_cover_bound.py`` run and tabulate.  :data:`TUNE` are the
maps the default preset's constants were chosen on, :data:`REPORT` the maps none was.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

import blockhash.index.tables.params as bp
from blockhash.evaluate.metrics import accuracy, exact_knn, false_negatives, far_queries
from blockhash.evaluate.photon_maps import PhotonMap, named, queries
from blockhash.index.block_hash_index import BlockHashIndex, OrphanWarning

#: Maps the default preset's constants were chosen on.
TUNE = ("uniform", "clustered", "caustic", "ring")
#: Maps no constant was chosen on.
REPORT = ("plane", "tilted", "room", "sphere", "venus", "tilted@1e4", "roomx0.001")
PRESETS = ("default", "paper")


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
    return scene_map(name, scenes) if name in ("ring", "venus") else named(name)


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


