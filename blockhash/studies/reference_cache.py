"""Mitsuba's renders of scene files, kept in a folder so that a comparison renders each only
once: the tests of the published corpus and of the Mitsuba files (``tests/conftest.py`` names
``tests/data/mitsuba_cache``) read Mitsuba's images from it instead of rendering them on
every run, as issue 56 asks of a suite that must stay under 10 minutes.

An image is kept under the SHA-256 of everything that decides it: the bytes of the scene file
and of every file it names (its ``<include>``s, meshes, textures and maps, followed through
the includes, looked up beside the file and in its ``<path>`` folders), the render's size,
samples, seed and parameters (``-D``), and Mitsuba's version and variant.  A change to any of
them is a new key, rendered again and kept beside the old ones; a file that names something
this lookup cannot find is keyed by what it found (Mitsuba's own load then fails or not as it
would).  ``BLOCKHASH_MITSUBA_CACHE`` names the folder; unset, nothing is kept.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from pathlib import Path

import numpy as np

#: The environment variable that names the folder of kept renders.
CACHE_ENV = "BLOCKHASH_MITSUBA_CACHE"

_NAMED = re.compile(r'(?:name="filename"\s+value|<include\s+filename)="([^"$]+)"')
_PATHS = re.compile(r'<path\s+value="([^"$]+)"')


def scene_files(path) -> list[Path]:
    """The scene file at ``path`` and every file it names that exists, through its includes
    (each once, in the order met)."""
    seen: list[Path] = []
    todo = [Path(path).resolve()]
    folders: list[Path] = []  # one search path for every file, as Mitsuba's resolver keeps
    while todo:
        current = todo.pop(0)
        if current in seen or not current.is_file():
            continue
        seen.append(current)
        if current.suffix.lower() != ".xml":
            continue
        text = current.read_text(errors="replace")
        folders += [current.parent] + [current.parent / p for p in _PATHS.findall(text)]
        for name in _NAMED.findall(text):
            found = [f / name for f in folders if (f / name).is_file()]
            todo.extend(p.resolve() for p in found[:1])
    return seen


def render_key(path, size, spp: int, seed: int, defines: dict | None, version: str) -> str:
    """The hex key of a render (module docstring); ``version`` Mitsuba's version and
    variant."""
    digest = hashlib.sha256()
    for f in scene_files(path):
        digest.update(f.name.encode())
        digest.update(f.read_bytes())
    digest.update(json.dumps([list(size), int(spp), int(seed),
                              sorted((str(k), str(v)) for k, v in (defines or {}).items()),
                              version]).encode())
    return digest.hexdigest()[:32]


def kept(key: str):
    """(image, seconds) kept under ``key`` in the folder :data:`CACHE_ENV` names, or None."""
    folder = os.environ.get(CACHE_ENV)
    if not folder or not (Path(folder) / f"{key}.npz").is_file():
        return None
    with np.load(Path(folder) / f"{key}.npz") as data:
        return data["image"].astype(np.float64), float(data["seconds"])


def keep(key: str, image: np.ndarray, seconds: float) -> None:
    """Keeps ``image`` (float32 on disk) and its render's ``seconds`` under ``key``, where
    :data:`CACHE_ENV` names a folder (made if missing)."""
    folder = os.environ.get(CACHE_ENV)
    if not folder:
        return
    Path(folder).mkdir(parents=True, exist_ok=True)
    part = Path(folder) / f"{key}.{os.getpid()}.npz"  # written whole, then renamed
    np.savez_compressed(part, image=np.asarray(image, np.float32), seconds=float(seconds))
    part.replace(Path(folder) / f"{key}.npz")
