"""The code blocks of README.md and docs/*.md are tests: Sybil runs each ```python block of a
page, in page order and in one namespace per page, from the repository's root (the pages'
paths, such as ``scenes/ring.toml``, are relative to it).  A block that cannot run here (one
that needs a Dask cluster) follows a ``<!-- skip: next -->`` comment and a sentence that says
so.  pyproject.toml's ``testpaths`` names README.md and docs/, so ``python -m pytest`` collects
them beside tests/.

The blocks render, so they need an OpenGL context: a machine without one skips them, unless
``BLOCKHASH_REQUIRE_GL`` names a backend (as in CI).

The suite runs in parallel processes (pytest-xdist, ``-n auto --dist loadfile``): each file's
tests in one process, in order, so the blocks of a page share their namespace.  The longest
files are handed out first (:data:`FIRST`).
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


#: The suite's longest files (``python -m pytest --durations=0``: one to two minutes of tests
#: each on two cores), collected first so that the parallel processes take them first: a file
#: runs whole in one process, and a long one begun last leaves the other processes idle.
FIRST = ("tests/test_tools_build.py", "tests/test_tools_passes.py",
         "tests/passes/test_executors.py", "tests/test_tools.py", "tests/gl/test_gl_lookup.py")


def pytest_collection_modifyitems(items):
    """:data:`FIRST`'s files first, in its order; every file's tests in their own order."""
    rank = {name: i for i, name in enumerate(FIRST)}

    def place(item):
        path = Path(item.path)
        name = path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else str(path)
        return rank.get(name, len(FIRST))

    items.sort(key=place)


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
