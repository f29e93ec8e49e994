"""The ``blockhash`` command line (also ``python -m blockhash``): one module per command or family.

- :mod:`~blockhash.cli.render`: ``blockhash render`` (its density-estimate flags in
  :mod:`~blockhash.cli.estimate`)
- :mod:`~blockhash.cli.index`: ``blockhash index``
- :mod:`~blockhash.cli.bench`: ``blockhash bench``
- :mod:`~blockhash.cli.images`: ``blockhash compare``, ``tolerance``, ``preview`` and ``info``
- :mod:`~blockhash.cli.tradeoff`: ``blockhash tradeoff``
- :mod:`~blockhash.cli.export`: ``blockhash export`` and ``blockhash reference``

:func:`build_parser` puts the commands together in the order ``blockhash --help`` lists them;
:func:`main` runs one and turns an input error into one line and exit status 2, its
parameters spelled as the flags that set them (:data:`.args.FLAGS`).
"""

from __future__ import annotations

import argparse
import sys

from blockhash import __version__
from blockhash.cli import bench, export, images, index, render, tradeoff
from blockhash.cli.args import FLAGS
from blockhash.errors import BlockHashError

#: Each command's parser, in the order of ``blockhash --help``.
COMMANDS = (index.add_index, images.add_info, bench.add_bench, render.add_render,
            tradeoff.add_tradeoff, images.add_compare, images.add_tolerance, export.add_export,
            export.add_reference, images.add_preview)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="blockhash", description="Low latency photon mapping with Block Hashing.")
    parser.add_argument("--version", action="version", version=f"blockhash {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in COMMANDS:
        add(sub)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except BlockHashError as exc:
        print(f"blockhash {args.command}: error: {exc.spelled(FLAGS)}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file the checks above did not foresee: one line, no traceback
        where = f" {exc.filename}" if exc.filename else ""
        print(f"blockhash {args.command}: error:{where} {exc.strerror or exc}; check the path and "
              "its permissions", file=sys.stderr)
        return 2
