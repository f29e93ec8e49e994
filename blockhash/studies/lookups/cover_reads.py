"""What the cover gather (:mod:`blockhash.index.lookups.cover`) reads per shading point, from
its CPU reference, on a scene's camera points or a photon map's query set
(``tools/cover_stats.py``)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from blockhash.frame.photon_radius import exact_radii2, own_radii2
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.lookups.cover import FINE, OCTAVE_STEPS, CoverGather


def scene_points(path: Path, photons: int, size: int, k: int):
    """(index, (m, 3) float32 shading points) of a scene's camera at size x size: the index
    over its caustic photons, one point per pixel that sees a surface."""
    from blockhash.frame.gbuffer import rasterize
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.frame.shading import shading_points
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.scene.loader import load_scene
    from blockhash.scene.model import MirrorMaterial

    scene = load_scene(path)
    pm = trace_caustic_photons(scene, photons, seed=scene.photons.seed)
    index = BlockHashIndex(pm.positions, k=k, directions=pm.directions, normals=pm.normals,
                           powers=pm.powers)
    gbuf = rasterize(scene.camera, scene.objects, size=(size, size))
    pts = shading_points(scene.camera, gbuf, scene.objects, SceneRays(scene.objects), (MirrorMaterial,))
    live = (pts.material >= 0).reshape(-1)
    return index, pts.position.reshape(-1, 3)[live]


def cover_row(name: str, index, q, k: int, exact: bool, fine=FINE, axis=None,
              steps=OCTAVE_STEPS) -> dict:
    """The gather built over ``index`` (radii exact or the render's own) with ``fine`` cells
    per coarse side, fine ``axis`` (None: the rule's) and ``steps`` octaves per doubling,
    queried at ``q``: its tables and what each point covers and reads."""
    r2 = (exact_radii2 if exact else own_radii2)(index, k)
    t = time.perf_counter()
    gather = CoverGather.build(index, r2, fine=fine, axis=axis, steps=steps)
    build = time.perf_counter() - t
    cov = gather.query(q)
    counts, cand = cov.counts, cov.candidates
    covered = counts > 0
    return {"map": name, "photons": len(index), "k": k, "queries": len(q), "fine_cells": fine,
            "octave_steps": steps,
            "octaves": len(gather.octaves), "windows": gather.windows,
            "fine_axis": "xyz"[gather.axis],
            "table_bytes_per_photon": gather.table_bytes / len(index),
            "record_bytes_per_photon": gather.records.nbytes / len(index),
            "covered_share": float(covered.mean()),
            "covering_mean": float(counts.mean()), "covering_max": int(counts.max(initial=0)),
            "covering_mean_covered": float(counts[covered].mean()) if covered.any() else 0.0,
            "candidates_mean": float(cand.mean()),
            "candidates_p99": float(np.quantile(cand, 0.99)),
            "candidates_max": int(cand.max(initial=0)),
            "ratio": float(cand.mean() / max(counts.mean(), 1e-12)),
            "probes_mean": float(np.mean(cov.probes)), "build_s": build,
            "radii": "exact" if exact else "own", "r2_mean": float(np.mean(r2)),
            "axis_choice": "auto" if axis is None else "xyz"[axis]}
