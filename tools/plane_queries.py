"""False negatives of queries on and just off the plane that holds every photon.

The ring's caustic photons all lie on the floor, y = 0, and so do the shading points the
caustic pass queries.  This measures, per preset, the false negatives (share of k) of
queries at the photons' own x and z moved 1 mm sideways, at heights ``--dy`` above the
floor: 0 (where the renderer queries) and a little above or below.

    python tools/plane_queries.py scenes/ring.toml --photons 100000
"""

from __future__ import annotations

from blockhash.photons.tracing import trace_caustic_photons
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser, count, listing, number
from blockhash.studies.lookups.accuracy_runs import plane_false_negatives


def height(text: str) -> str:
    """A height above the floor, kept as written (the table's header shows it)."""
    number(text)
    return text.strip()


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.add_argument("scene", type=p.scene, help="a scene file or a name under scenes/")
    p.photons(100_000)
    p.add_argument("--queries", type=count, default=2_000, help="queries (default 2,000)")
    p.add_argument("--k", type=count, default=50)
    p.add_argument("--A", type=count, default=8)
    p.add_argument("--dy", type=listing(height), default="0,1e-7,-1e-7,1e-3",
                   help="query heights above the floor (default 0,1e-7,-1e-7,1e-3)")
    p.add_argument("--seed", type=int, default=1)
    args = p.parse_args(argv)
    photons = trace_caustic_photons(load_scene(args.scene), args.photons, seed=args.seed)
    y = photons.positions[:, 1]
    shown = args.scene.relative_to(p.root) if args.scene.is_relative_to(p.root) else args.scene
    print(f"{shown}: {len(photons):,} photons, y in [{y.min():.3g}, {y.max():.3g}], "
          f"k={args.k}, A={args.A}, {args.queries:,} queries")
    print(f"{'preset':<8} " + " ".join(f"{'dy=' + d:>12}" for d in args.dy))
    for preset in ("default", "paper"):
        fn = plane_false_negatives(photons.positions, args.k, args.A, preset,
                                   [float(d) for d in args.dy], args.queries)
        print(f"{preset:<8} " + " ".join(f"{f:>12.1%}" for f in fn))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
