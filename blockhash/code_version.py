"""The code's own version: a digest of the package's source, for caches that must never
outlive the code that filled them (numba's compiled functions here, the light tracer's
reference images in :mod:`blockhash.reference.lighttrace`).

numba keys a cached function by its own file's timestamp and size, not by the source of
the functions it inlines from other modules (``inline="always"``), so an edit to an
inlined helper, or an upgrade over an old ``__pycache__``, could load machine code built
from the old helper.  :func:`configure` runs once, on ``import blockhash``, before any
compiled function is defined: it points ``numba.config.CACHE_DIR`` at
``<base>/blockhash-<version>-<digest>`` (the digest of every module that imports numba),
with ``<base>`` the user's ``NUMBA_CACHE_DIR``
when set, else ``$XDG_CACHE_HOME/blockhash/numba`` (``~/.cache/blockhash/numba``).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent


#: What a compiled module's text holds.
COMPILED = b"import numba"


def _modules(package: Path, parts) -> list[tuple[str, bytes]]:
    """(path relative to the package, text) of every module under ``parts``, folders or
    modules of the package, sorted by path; each file read once."""
    paths = {p for part in parts for p in ([package / part] if part.endswith(".py")
                                            else (package / part).rglob("*.py"))}
    root = package.resolve()
    return sorted((p.resolve().relative_to(root).as_posix(), p.read_bytes())
                  for p in paths if "__pycache__" not in p.parts)


def source_digest(package: Path = PACKAGE, parts=(".",), containing: bytes | None = None) -> str:
    """16 hex digits of SHA-256 over every module (path and text) under ``parts`` (default:
    the whole package), or only those whose text holds ``containing``."""
    h = hashlib.sha256()
    for rel, text in _modules(package, parts):
        if containing is None or containing in text:
            h.update(rel.encode())
            h.update(b"\0")
            h.update(text)
    return h.hexdigest()[:16]


def compiled_modules(package: Path = PACKAGE) -> tuple[str, ...]:
    """The package's modules that numba compiles (those that import it), relative paths."""
    return tuple(rel for rel, text in _modules(package, (".",)) if COMPILED in text)


def cache_dir(version: str, package: Path = PACKAGE) -> Path:
    """The cache folder for this version and the source of every compiled module (an
    inlined helper is always in one of them)."""
    base = os.environ.get("NUMBA_CACHE_DIR")
    if not base:
        xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        base = os.path.join(xdg, "blockhash", "numba")
    digest = source_digest(package, containing=COMPILED)
    return Path(base) / f"blockhash-{version}-{digest}"


def configure(version: str) -> Path:
    """Point numba's cache at :func:`cache_dir` (call before any ``cache=True`` function
    is defined); returns the folder."""
    import numba

    folder = cache_dir(version)
    numba.config.CACHE_DIR = str(folder)
    return folder
