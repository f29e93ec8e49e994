"""False negatives of queries on and just off the plane that holds every photon.

The ring's caustic photons all lie on the floor, y = 0, and so do the shading points the
caustic pass queries.  This measures, per preset, the false negatives (share of k) of
queries at the photons' own x and z moved 1 mm sideways, at heights ``--dy`` above the
floor: 0 (where the renderer queries) and a little above or below.

    python tools/plane_queries.py scenes/ring.toml --photons 100000
"""

from __future__ import annotations

import argparse
import warnings

from blockhash import BlockHashIndex
from blockhash.evaluate.metrics import accuracy, exact_knn
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.scene.loader import load_scene


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--photons", type=int, default=100_000)
    parser.add_argument("--queries", type=int, default=2_000)
    parser.add_argument("--k", type=int, default=50)
    parser.add_argument("--A", type=int, default=8)
    parser.add_argument("--dy", default="0,1e-7,-1e-7,1e-3")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    photons = trace_caustic_photons(load_scene(args.scene), args.photons, seed=args.seed)
    y = photons.positions[:, 1]
    print(f"{args.scene}: {len(photons):,} photons, y in [{y.min():.3g}, {y.max():.3g}], "
          f"k={args.k}, A={args.A}, {args.queries:,} queries")
    print(f"{'preset':<8} " + " ".join(f"{'dy=' + d:>12}" for d in args.dy.split(",")))
    for preset in ("default", "paper"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            index = BlockHashIndex(photons.positions, k=args.k, A=args.A, preset=preset)
        cells = []
        for dy in (float(d) for d in args.dy.split(",")):
            q = photons.positions[:args.queries] * [1.0, 0.0, 1.0] + [1e-3, dy, 0.0]
            acc = accuracy(index.query(q), exact_knn(index.positions, q, args.k), len(index))
            cells.append(f"{acc.fn_fraction:>12.1%}")
        print(f"{preset:<8} " + " ".join(cells))


if __name__ == "__main__":
    main()
