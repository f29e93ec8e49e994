"""The code blocks of README.md and docs/*.md are tests: Sybil runs each ```python block of a
page, in page order and in one namespace per page, from the repository's root (the pages'
paths, such as ``scenes/ring.toml``, are relative to it).  A block that cannot run here (one
that needs a Dask cluster) follows a ``<!-- skip: next -->`` comment and a sentence that says
so.  pyproject.toml's ``testpaths`` names README.md and docs/, so ``python -m pytest`` collects
them beside tests/.

The blocks render, so they need an OpenGL context: a machine without one skips them, unless
``BLOCKHASH_REQUIRE_GL`` names a backend (as in CI).

The suite runs in parallel processes (pytest-xdist, ``-n auto --dist loadfile``): each file's
tests in one process, in order, so the blocks of a page share their namespace.
"""

import os
from pathlib import Path

import pytest
from sybil import Sybil
from sybil.parsers.markdown import PythonCodeBlockParser, SkipParser

ROOT = Path(__file__).resolve().parent


def _setup(namespace):
    from blockhash.errors import GLUnavailableError
    from blockhash.gl.context import get_context

    try:
        get_context()
    except GLUnavailableError as exc:
        if not os.environ.get("BLOCKHASH_REQUIRE_GL"):
            pytest.skip(f"no OpenGL context for the page's examples: {exc}")
        raise
    namespace["__name__"] = "__main__"  # a page's blocks run as the script a user pastes them into
    namespace["_cwd"] = os.getcwd()
    os.chdir(ROOT)


def _teardown(namespace):
    if "_cwd" in namespace:
        os.chdir(namespace["_cwd"])


pytest_collect_file = Sybil(
    parsers=[PythonCodeBlockParser(), SkipParser()],
    patterns=["README.md", "docs/*.md"],
    excludes=["docs/_build/*"],
    path=str(ROOT),
    setup=_setup,
    teardown=_teardown,
).pytest()
