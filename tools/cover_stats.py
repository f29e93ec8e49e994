"""The cover gather's reads per shading point, from its CPU reference (blockhash/index/lookups/cover.py).

For each scene (its camera's shading points, one per pixel) and each photon map of
``tools/eval_accuracy.py`` (its query set: half drawn like the photons, half uniform over the
map's surfaces, :func:`blockhash.evaluate.photon_maps.queries`): the photons covering each
point (mean, max), the candidates read (mean, p99, max), their ratio, the windows probed, the
octaves and the window table's bytes per photon.  Radii are the render's own
(``own_radii2``) unless --exact-radii.  ``--fine``, ``--axis`` and ``--steps`` build the
gather with other fine cells per coarse side, fine axes or octave factors (one row each), to
compare layouts.

usage: python tools/cover_stats.py [--scenes scenes/ring.toml,...] [--maps caustic,...]
                                   [--photons 200000] [--size 256] [--fine 1,2,4]
                                   [--axis auto,x,y,z] [--steps 1,2,3] [--json PATH]
"""

import argparse
import json
import sys
import time

import numpy as np

from blockhash.evaluate.photon_maps import EXTREMES, MAPS, named, queries
from blockhash.frame.photon_radius import exact_radii2, own_radii2
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.lookups.cover import FINE, OCTAVE_STEPS, CoverGather


def scene_points(path, photons, size, k):
    """(index, (m, 3) float32 shading points) of a scene's camera at size x size."""
    from blockhash.frame.gbuffer import rasterize
    from blockhash.frame.shading import SceneRays, shading_points
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


#: The photon maps of tools/eval_accuracy.py but its scene maps (ring, venus: --scenes).
MAP_NAMES = (*MAPS, *EXTREMES)


def stats(name, index, q, k, exact, fine=FINE, axis=None, steps=OCTAVE_STEPS):
    r2 = (exact_radii2 if exact else own_radii2)(index, k)
    t = time.perf_counter()
    gather = CoverGather.build(index, r2, fine=fine, axis=axis, steps=steps)
    build = time.perf_counter() - t
    cov = gather.query(q)
    counts, cand = cov.counts, cov.candidates
    covered = counts > 0
    row = {"map": name, "photons": len(index), "k": k, "queries": len(q), "fine_cells": fine,
           "octave_steps": steps,
           "octaves": len(gather.octaves), "windows": gather.windows,
           "fine_axis": "xyz"[gather.axis],
           "table_bytes_per_photon": gather.table_bytes / len(index),
           "record_bytes_per_photon": gather.records.nbytes / len(index),
           "covered_share": float(covered.mean()),
           "covering_mean": float(counts.mean()), "covering_max": int(counts.max(initial=0)),
           "covering_mean_covered": float(counts[covered].mean()) if covered.any() else 0.0,
           "candidates_mean": float(cand.mean()), "candidates_p99": float(np.quantile(cand, 0.99)),
           "candidates_max": int(cand.max(initial=0)),
           "ratio": float(cand.mean() / max(counts.mean(), 1e-12)),
           "probes_mean": float(np.mean(cov.probes)), "build_s": build,
           "radii": "exact" if exact else "own", "r2_mean": float(np.mean(r2))}
    print(f"{name:>10} (fine {fine}, steps {steps}): {row['octaves']} octaves, {row['windows']:,} "
          f"windows (fine axis {row['fine_axis']}) "
          f"({row['table_bytes_per_photon']:.1f} B/photon); covering mean {row['covering_mean']:.1f} "
          f"max {row['covering_max']}; candidates mean {row['candidates_mean']:.0f} p99 "
          f"{row['candidates_p99']:.0f} max {row['candidates_max']}; ratio {row['ratio']:.1f}x; "
          f"windows probed {row['probes_mean']:.0f}", flush=True)
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default="scenes/ring.toml,scenes/venus.toml,scenes/glass.toml,"
                                       "scenes/corner.toml")
    p.add_argument("--maps", default=",".join(MAP_NAMES),
                   help="photon maps of tools/eval_accuracy.py, queried with its query sets")
    p.add_argument("--photons", type=float, default=2e5)
    p.add_argument("--queries", type=int, default=65536, help="queries per photon map")
    p.add_argument("--size", type=int, default=256, help="scene image side (one point per pixel)")
    p.add_argument("--k", type=int, default=50)
    p.add_argument("--fine", default=str(FINE), help="fine cells per coarse side, comma-separated")
    p.add_argument("--axis", default="auto", help="fine axes, comma-separated: auto, x, y, z")
    p.add_argument("--steps", default=str(OCTAVE_STEPS),
                   help="octaves per doubling of the cell side, comma-separated (1, 2, 3)")
    p.add_argument("--exact-radii", action="store_true", help="cKDTree radii instead of the render's")
    p.add_argument("--json", help="write the rows here")
    args = p.parse_args(argv)
    n = int(args.photons)
    layouts = [(int(f), None if a == "auto" else "xyz".index(a), int(st))
               for st in args.steps.split(",") for f in args.fine.split(",")
               for a in args.axis.split(",")]
    rows = []

    def measure(name, index, q):
        for fine, axis, steps in layouts:
            rows.append(stats(name, index, q, args.k, args.exact_radii, fine, axis, steps))
            rows[-1]["axis_choice"] = "auto" if axis is None else "xyz"[axis]

    for path in [s for s in args.scenes.split(",") if s]:
        index, q = scene_points(path, n, args.size, args.k)
        measure(path.rsplit("/", 1)[-1].removesuffix(".toml"), index, q)
    for name in [m for m in args.maps.split(",") if m]:
        pm = named(name)
        index = BlockHashIndex(pm.photons(n, np.random.default_rng(7)), k=args.k)
        measure(name, index, queries(pm, args.queries, np.random.default_rng(8)))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"command": "python tools/cover_stats.py " + " ".join(argv or sys.argv[1:]),
                       "rows": rows}, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
