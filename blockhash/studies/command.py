"""What the commands in ``tools/`` share, so that each is a thin main over the package (as
pbrt-v4's ``cmd/`` tools are): :class:`ToolParser`, an ``argparse`` parser with the options
that recur (photon counts, image sizes, scenes, a JSON output) typed one way everywhere, the
scenes of the checkout a tool runs from, :func:`timed`, and :func:`in_checkout`, a child
process on another checkout's code (a ``git worktree`` of the commit a tool compares with).

The argument types accept what the docs quote: a count as ``200000``, ``200_000`` or ``2e5``;
a size as ``128`` (square) or ``128x96``; lists comma-separated.  A scene is a path (relative
to the working directory), a path relative to the checkout (``scenes/ring.toml``) or a bare
name under the checkout's ``scenes/`` (``ring``), so a tool runs from any working directory.
Every bad value is an ``argparse`` error naming the option, the value and what is expected.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: Scene file suffixes a bare name may take under ``scenes/``, in the order tried.
SCENE_SUFFIXES = (".toml", ".xml")


def count(text: str) -> int:
    """A positive whole count: ``200000``, ``200_000`` or ``2e5``."""
    try:
        value = float(str(text).replace("_", ""))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected a whole number such as 200000 or 2e5") from None
    if not (math.isfinite(value) and value == int(value) and value >= 1):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number >= 1 (such as 2e5)")
    return int(value)


def size(text: str) -> tuple[int, int]:
    """An image size, ``WIDTHxHEIGHT`` or one number for a square: (width, height)."""
    parts = str(text).lower().split("x")
    try:
        w, h = (int(parts[0]), int(parts[0])) if len(parts) == 1 else (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected a size such as 256 (square) or 256x192") from None
    if w < 1 or h < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: width and height must be >= 1")
    return w, h


def side(text: str) -> int:
    """A square image's side: ``256`` or ``256x256``."""
    w, h = size(text)
    if w != h:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a square size (256 or 256x256)")
    return w


def number(text: str) -> float:
    """A finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r}: expected a finite number")
    return value


def listing(item):
    """The type of a comma-separated list of ``item`` (empty items skipped; ``""`` is [])."""
    def parse(text: str) -> list:
        return [item(part.strip()) for part in str(text).split(",") if part.strip()]
    parse.__name__ = f"list of {getattr(item, '__name__', 'values')}"
    return parse


class ToolParser(argparse.ArgumentParser):
    """The parser of a tool: its description from the tool's docstring (``doc``), and the
    shared options (:meth:`photons`, :meth:`size`, :meth:`scenes`, :meth:`json_output`).
    ``tool_file`` (the tool's ``__file__``) locates the checkout whose ``scenes/`` a bare
    scene name means."""

    def __init__(self, doc: str | None, tool_file: str, **kwargs):
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)
        super().__init__(description=doc, **kwargs)
        self.root = Path(tool_file).resolve().parents[1]

    def scene(self, text: str) -> Path:
        """A scene file: ``text`` as a path, else relative to the checkout, else a name under
        its ``scenes/``."""
        given = Path(text).expanduser()
        tries = [given, self.root / given] + [self.root / "scenes" / f"{text}{suffix}"
                                              for suffix in SCENE_SUFFIXES]
        for path in tries:
            if path.is_file():
                return path.resolve()
        names = sorted(p.stem for p in (self.root / "scenes").glob("*.toml"))
        raise argparse.ArgumentTypeError(
            f"{text!r}: no such scene file; give a path or one of {', '.join(names)}")

    def photons(self, default, *, many: bool = False, flag: str = "--photons", help=None):
        """``--photons N`` (or ``N,N,...`` with ``many``): photon counts."""
        self.add_argument(flag, type=listing(count) if many else count, default=default,
                          help=(help or "photons") + f" (default {_shown(default)})")

    def size(self, default, *, many: bool = False, square: bool = True, flag: str = "--size",
             help=None):
        """``--size S`` (a square's side, ``256`` or ``256x256``; ``square=False``: a
        (width, height) pair) or ``--sizes S,S,...`` with ``many``."""
        kind = side if square else size
        self.add_argument(flag, type=listing(kind) if many else kind, default=default,
                          help=(help or "image size") + f" (default {_shown(default)})")

    def scenes(self, default, *, many: bool = True, flag: str | None = None, help=None,
               **kwargs):
        """``--scenes a,b`` (paths or names under ``scenes/``; ``many=False``: ``--scene``; a
        ``flag`` without dashes is a positional, e.g. with ``nargs="?"``), given as resolved
        paths."""
        flag = flag or ("--scenes" if many else "--scene")
        parse = listing(self.scene) if many else self.scene
        self.add_argument(flag, type=parse, default=parse(default),
                          help=(help or "scene files or names under scenes/")
                          + f" (default {default})", **kwargs)

    def json_output(self, help="also write the results as JSON to this file"):
        """``--json PATH``."""
        self.add_argument("--json", type=Path, metavar="PATH", help=help)


def _shown(default) -> str:
    if isinstance(default, (list, tuple)):
        return ",".join(_shown(d) for d in default)
    return f"{default:,}" if isinstance(default, int) else str(default)


def timed(fn, *args, **kwargs):
    """``(fn(*args, **kwargs), seconds)`` on the wall clock (``time.perf_counter``)."""
    t = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t


def in_checkout(checkout, code: str, args, what: str, env=None):
    """The JSON value a fresh Python process prints last running ``code`` with ``args`` on
    ``checkout``'s package (its ``PYTHONPATH``; ``env`` added to the environment), from the
    temporary folder; a failure ends the tool naming ``what`` and the child's error."""
    env = {**os.environ, "PYTHONPATH": str(Path(checkout).resolve()), **(env or {})}
    proc = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                          text=True, env=env, cwd=tempfile.gettempdir())
    if proc.returncode:
        raise SystemExit(f"{what} on {checkout} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def write_json(path, data) -> None:
    """``data`` as indented JSON at ``path`` (its folder made), for a tool's ``--json``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, default=_plain) + "\n")


def _plain(value):
    """numpy scalars and arrays, and paths, as JSON values."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")
