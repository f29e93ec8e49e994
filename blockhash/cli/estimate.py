"""Command-line flags of the caustic density estimate (``blockhash render``).

``--estimate {conserving,unbiased,paper}``, ``--filter {none,cone,epanechnikov,silverman}``,
``--normal-test COS|off``, ``--disc FRACTION|off``; each left out keeps the default of
:class:`blockhash.frame.estimate.EstimateOptions`.
"""

from __future__ import annotations

import argparse

from blockhash.frame.estimate import ESTIMATES, FILTERS, EstimateOptions

_DEFAULT = EstimateOptions()


def _number_or_off(flag: str, low: float, high: float):
    def parse(text: str):
        if text.strip().lower() == "off":
            return "off"
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{flag} {text!r}: expected a number in [{low:g}, "
                                             f"{high:g}] or 'off'") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{flag} {text!r}: expected a number in [{low:g}, "
                                             f"{high:g}] or 'off'")
        return value
    return parse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Add the density estimate's flags to a subcommand's parser."""
    g = p.add_argument_group("density estimate (docs/radiance-estimate.md)")
    g.add_argument("--estimate", choices=ESTIMATES, default=None,
                   help=f"conserving: each photon over a disc of its own radius (keeps the "
                        f"photons' power); unbiased: the farthest of the k photons, on the "
                        f"circle, left out (sum of k-1 over pi r^2); paper: all k (overestimates "
                        f"by k/(k-1)); default {_DEFAULT.estimate}")
    g.add_argument("--filter", choices=FILTERS, default=None,
                   help=f"photon weight by distance: none (box), cone (Jensen), epanechnikov, "
                        f"silverman; default {_DEFAULT.filter}")
    g.add_argument("--normal-test", type=_number_or_off("--normal-test", -1.0, 1.0), default=None,
                   metavar="COS|off",
                   help=f"a photon counts where dot(its surface normal, shading normal) >= COS; "
                        f"'off' to count photons of every surface; default {_DEFAULT.normal_cos}")
    g.add_argument("--disc", type=_number_or_off("--disc", 0.0, float("inf")), default=None,
                   metavar="FRACTION|off",
                   help="flattened neighbourhood: photons within FRACTION * r of the tangent "
                        f"plane; default {_DEFAULT.disc or 'off'}")


def options_from(args) -> EstimateOptions:
    """The EstimateOptions that the parsed flags ask for."""
    from dataclasses import replace

    opt = EstimateOptions.of(None, estimate=args.estimate, filter=args.filter)
    if args.normal_test is not None:
        opt = replace(opt, normal_cos=None if args.normal_test == "off" else args.normal_test)
    if args.disc is not None:
        opt = replace(opt, disc=None if args.disc == "off" else args.disc)
    return opt
