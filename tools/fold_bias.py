"""How much flux the k-nearest-neighbour estimate adds at a caustic's fold and at a step edge.

    python tools/fold_bias.py                       # fold and step; N = 1e5, 4e5, 1.6e6; k = 25, 50, 100
    python tools/fold_bias.py --shapes fold --photons 1000000 --ks 50
    python tools/fold_bias.py --estimate conserving   # each photon over its own disc

Photons of total power 1 on the unit square of a plane, uniform in y and, in x,

* ``fold``: x = u^2, density 1 / (2 sqrt(x)) on (0, 1) and nothing at x < 0: the profile
  across a fold line of a caustic (the cardioid's arcs), infinite at the fold;
* ``step``: x uniform on (0, 1): a sharp edge of constant density;
* ``smooth``: x normal (0.3, 0.1): no edge.

The estimate of blockhash.frame.estimate (``--estimate unbiased``: the k-1 nearest photons
with the filter's weights, over pi r^2, r the k-th's distance; ``--estimate conserving``:
each of the k nearest photons over its own disc, of the radius to its
round(k - 2 sqrt(k))-th nearest other photon, blockhash.frame.photon_radius; exact kNN
in 2D) is integrated
over the window x in (-0.2, 0.5), y in (0.25, 0.75) with stratified jittered points
(``--points`` per axis along x, half as many along y), and divided by the power of the
photons inside the window: 1 for an estimate that conserved the photons' power.  The
window's x-edge at 0.5 and its y-edges cross smooth density only, so what is left over
is the estimate's own excess at the edge or fold (blockhash.studies.density.fold_bias).
"""

from __future__ import annotations

import argparse

from blockhash.frame.estimate import FILTERS
from blockhash.studies.command import ToolParser, count, listing
from blockhash.studies.density.fold_bias import ESTIMATES, SHAPES, flux_ratio


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.add_argument("--shapes", type=listing(_shape), default=["fold", "step"],
                   help=f"{', '.join(SHAPES)} (comma-separated; default fold,step)")
    p.photons([100_000, 400_000, 1_600_000], many=True, help="photon counts")
    p.add_argument("--ks", type=listing(count), default=[25, 50, 100],
                   help="k (comma-separated; default 25,50,100)")
    p.add_argument("--points", type=count, default=1500,
                   help="jittered points along x (default 1500)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--estimate", choices=ESTIMATES, default="unbiased")
    args = p.parse_args(argv)
    filters = list(FILTERS)
    print("| shape | N | k | " + " | ".join(filters) + " |")
    print("|---|---|---|" + "---|" * len(filters))
    for shape in args.shapes:
        for n in args.photons:
            for k in args.ks:
                r = flux_ratio(shape, n, k, filters, points=args.points, seed=args.seed,
                               estimate=args.estimate)
                print(f"| {shape} | {n:,} | {k} | " + " | ".join(f"{r[f]:.4f}" for f in filters)
                      + " |", flush=True)
    return 0


def _shape(text: str) -> str:
    if text not in SHAPES:
        raise argparse.ArgumentTypeError(f"{text!r}: expected one of {', '.join(SHAPES)}")
    return text


if __name__ == "__main__":
    raise SystemExit(main())
