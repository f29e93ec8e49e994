"""What several commands share: the argument type of ``--size`` (``WIDTHxHEIGHT``, or one
number for a square), and
:data:`FLAGS`, the command line's names for the library's parameters, with which
:func:`blockhash.cli.main` spells a library error's message (:meth:`blockhash.errors.BlockHashError.spelled`)."""

from __future__ import annotations

import argparse

from blockhash.studies.command import size as image_size

#: The flag that sets each library parameter an error may name (the one place the command line
#: maps its flags onto the library's keywords).
FLAGS = {"passes": "--passes ", "seconds": "--time ", "target_error": "--target-error ",
         "alpha": "--alpha ", "footprint": "--footprint ", "photons": "--photons ", "k": "--k ",
         "A": "--A ", "workers": "--workers ", "size": "--size", "spp": "--spp ",
         "seed": "--seed ", "seeds": "--seeds ", "margin": "--margin ", "through": "--through ",
         "max_rms": "--max-rms ", "max_rel_rms": "--max-rel-rms ", "max_flip": "--max-flip ",
         "mask": "--mask ", "drop_specular": "--drop-specular", "study_path": "--tradeoff ",
         "out_dir": "-o "}


def size(text: str) -> tuple[int, int]:
    """``--size``: (width, height) from ``WIDTHxHEIGHT`` or one number for a square."""
    try:
        return image_size(text)
    except argparse.ArgumentTypeError as e:
        raise argparse.ArgumentTypeError(f"--size {e}") from None


def size_help(default: str = "the camera's") -> str:
    """``--size``'s help, with its ``default``."""
    return f"image size WIDTHxHEIGHT or one number for a square (default: {default})"


#: The exit status of a render stopped by Ctrl-C (as a shell reports SIGINT).
INTERRUPTED = 130



def define_option(parser) -> None:
    """``-D NAME=VALUE``, repeatable: a Mitsuba XML file's ``$NAME``, as Mitsuba's own ``-D``."""
    parser.add_argument("-D", dest="define", action="append", default=[], metavar="NAME=VALUE",
                        type=_define, help="a Mitsuba XML scene's parameter $NAME, over its "
                        "<default> (as Mitsuba's -D); repeatable")


def _define(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"-D {text!r}: expected NAME=VALUE such as spp=64")
    return name.strip(), value.strip()


def defines(pairs) -> dict:
    """``-D`` pairs as the loader's ``defines`` (the last of a name wins, as Mitsuba's)."""
    return dict(pairs or [])
