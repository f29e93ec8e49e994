"""Argument types that several commands share: ``--size WIDTHxHEIGHT``."""

from __future__ import annotations

import argparse


def size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected WIDTHxHEIGHT such as 512x512") from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"--size {text!r}: width and height must be positive")
    return w, h
