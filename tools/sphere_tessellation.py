"""How fine a generated sphere must be for its caustic: each subdivision against a finer one.

The glass scene's caustic photons are traced with the same seed through the ball at each
icosphere subdivision (the same emitted photons, so the maps differ by the tessellation
alone) and binned on the floor in 2 mm cells over the caustic; the relative L2 difference of
each histogram from the finest one's, and the stored flux ratio, say what the facets cost.

    python tools/sphere_tessellation.py                     # scenes/glass.toml, s = 3 .. 7
    python tools/sphere_tessellation.py --photons 2e6 --finest 8
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from blockhash.photons.tracing import trace_caustic_photons
from blockhash.scene import meshes
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count, listing, number, timed


def with_subdivisions(scene, s: int):
    objects = []
    for o in scene.objects:
        if o.is_dielectric:
            lo, hi = o.mesh.bounds
            c, r = (lo + hi) / 2, float((hi - lo).max() / 2)
            o = dataclasses.replace(o, mesh=meshes.sphere(center=c, radius=r, subdivisions=s))
        objects.append(o)
    return dataclasses.replace(scene, objects=tuple(objects))


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.add_argument("scene", nargs="?", type=p.scene, default="glass",
                   help="scene file or name under scenes/ (default glass)")
    p.photons(1_000_000, help="photons stored")
    p.add_argument("--subdivisions", type=listing(count), default=[3, 4, 5, 6],
                   help="icosphere subdivisions compared (default 3,4,5,6)")
    p.add_argument("--finest", type=count, default=7, help="the subdivision compared with")
    p.add_argument("--cell", type=number, default=0.002, help="histogram cell, metres")
    a = p.parse_args(argv)
    scene = load_scene(a.scene)
    maps = {s: timed(trace_caustic_photons, with_subdivisions(scene, s), a.photons,
                     seed=scene.photons.seed)
            for s in a.subdivisions + [a.finest]}
    ref = maps[a.finest][0]
    lo = np.percentile(ref.positions, 1, axis=0)
    hi = np.percentile(ref.positions, 99, axis=0)
    bins = [np.arange(lo[i], hi[i] + a.cell, a.cell) for i in (0, 2)]

    def hist(pm):
        h, _, _ = np.histogram2d(pm.positions[:, 0], pm.positions[:, 2], bins=bins,
                                 weights=pm.powers[:, 0])
        return h
    href = hist(ref)
    print(f"{a.scene.name}: {a.photons:,} photons stored, histogram "
          f"{len(bins[0]) - 1} x {len(bins[1]) - 1} cells of {a.cell * 1e3:g} mm over the "
          f"caustic; against subdivisions {a.finest}")
    print(f"{'subdiv':>6} {'triangles':>10} {'rel. L2 vs finest':>18} {'flux ratio':>11} {'trace s':>8}")
    for s, (pm, secs) in maps.items():
        h = hist(pm)
        err = np.linalg.norm(h - href) / np.linalg.norm(href)
        flux = pm.total_power[0] / ref.total_power[0]
        print(f"{s:>6} {20 * 4 ** s:>10,} {err:>18.4f} {flux:>11.4f} {secs:>8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
