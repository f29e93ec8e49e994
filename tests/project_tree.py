"""The project's own files, for the tests that read the tree.

A checkout holds more than the project: a virtual environment made inside it (``.venv/``,
``venv/``), build outputs, caches and whatever else its user put there. The tests that scan
the tree read only the files git tracks; where there is no git (an unpacked sdist), they walk
the tree and leave out hidden folders, environments (any folder with a ``pyvenv.cfg``),
build outputs and caches.
"""

import subprocess
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# Folders a walk never enters (without git): environments, build outputs and caches.
SKIPPED_DIRS = frozenset({"venv", "env", "build", "dist", "node_modules", "__pycache__",
                          "site-packages", "htmlcov", "out"})


def skipped_dir(d: Path) -> bool:
    """Whether ``d`` is no part of the project: hidden, an environment, a build output or a cache."""
    return (d.name.startswith(".") or d.name in SKIPPED_DIRS or d.name.endswith(".egg-info")
            or (d / "pyvenv.cfg").exists())


def _walked(top: Path) -> list[Path]:
    found = []
    for p in sorted(top.iterdir()):
        if p.is_dir() and not p.is_symlink():
            if not skipped_dir(p):
                found += _walked(p)
        elif p.is_file():
            found.append(p)
    return found


@cache
def _tracked() -> tuple[Path, ...] | None:
    """The files git tracks, or None without git (or outside a git checkout)."""
    try:
        run = subprocess.run(["git", "ls-files", "-z", "--cached"],
                             cwd=ROOT, capture_output=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return None
    if run.returncode != 0:
        return None
    names = [n for n in run.stdout.decode().split("\0") if n]
    return tuple(p for p in (ROOT / n for n in names) if p.is_file())


def project_files(*patterns: str, under: str | None = None) -> list[Path]:
    """The project's files whose names match any of ``patterns`` (``fnmatch`` globs on the
    file name; all files when none), optionally only those under the folder ``under``."""
    files = _tracked()
    if files is None:
        files = tuple(_walked(ROOT))
    top = ROOT / under if under else ROOT
    return sorted(p for p in files
                  if p.is_relative_to(top) and "__pycache__" not in p.parts
                  and (not patterns or any(p.match(g) for g in patterns)))
