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

import numpy as np

from blockhash.evaluate.photon_maps import EXTREMES, MAPS, queries
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.lookups.cover import FINE, OCTAVE_STEPS
from blockhash.studies.command import ToolParser, count, listing
from blockhash.studies.lookups import accuracy_runs as ea
from blockhash.studies.lookups.cover_reads import cover_row, scene_points

#: The photon maps of tools/eval_accuracy.py but its scene maps (ring, venus: --scenes).
MAP_NAMES = (*MAPS, *EXTREMES)


def axis(text: str):
    """A fine axis: ``auto`` (None, the rule's) or x, y, z (0, 1, 2)."""
    if text not in ("auto", "x", "y", "z"):
        raise argparse.ArgumentTypeError(f"{text!r}: expected auto, x, y or z")
    return None if text == "auto" else "xyz".index(text)


def main(argv=None):
    p = ToolParser(__doc__, __file__)
    p.scenes("scenes/ring.toml,scenes/venus.toml,scenes/glass.toml,scenes/corner.toml")
    p.add_argument("--maps", type=listing(ea.map_name), default=list(MAP_NAMES),
                   help="photon maps of tools/eval_accuracy.py, queried with its query sets "
                        "('' for none)")
    p.photons(200_000)
    p.add_argument("--queries", type=count, default=65536, help="queries per photon map")
    p.size(256, help="scene image side (one point per pixel)")
    p.add_argument("--k", type=count, default=50)
    p.add_argument("--fine", type=listing(count), default=[FINE],
                   help="fine cells per coarse side, comma-separated")
    p.add_argument("--axis", type=listing(axis), default=[None],
                   help="fine axes, comma-separated: auto, x, y, z")
    p.add_argument("--steps", type=listing(count), default=[OCTAVE_STEPS],
                   help="octaves per doubling of the cell side, comma-separated (1, 2, 3)")
    p.add_argument("--exact-radii", action="store_true", help="cKDTree radii instead of the render's")
    p.json_output("write the rows here")
    args = p.parse_args(argv)
    layouts = [(f, a, st) for st in args.steps for f in args.fine for a in args.axis]
    rows = []

    def measure(name, index, q):
        for fine, ax, steps in layouts:
            row = cover_row(name, index, q, args.k, args.exact_radii, fine, ax, steps)
            rows.append(row)
            print(f"{name:>10} (fine {fine}, steps {steps}): {row['octaves']} octaves, "
                  f"{row['windows']:,} windows (fine axis {row['fine_axis']}) "
                  f"({row['table_bytes_per_photon']:.1f} B/photon); covering mean "
                  f"{row['covering_mean']:.1f} max {row['covering_max']}; candidates mean "
                  f"{row['candidates_mean']:.0f} p99 {row['candidates_p99']:.0f} max "
                  f"{row['candidates_max']}; ratio {row['ratio']:.1f}x; "
                  f"windows probed {row['probes_mean']:.0f}", flush=True)

    for path in args.scenes:
        measure(path.stem, *scene_points(path, args.photons, args.size, args.k))
    for name in args.maps:
        pm = ea.photon_map(name, p.root / "scenes")
        index = BlockHashIndex(pm.photons(args.photons, np.random.default_rng(7)), k=args.k)
        measure(name, index, queries(pm, args.queries, np.random.default_rng(8)))
    if args.json:
        ea.save_rows(args.json, __file__, argv, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
