"""Shared fixtures: seeded generators, small photon sets, GL contexts."""

import os

import numpy as np
import pytest

from blockhash.index.datasets import DISTRIBUTIONS


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(params=sorted(DISTRIBUTIONS))
def distribution(request):
    """Name of each synthetic photon distribution."""
    return request.param


def photon_set(name: str, n: int, seed: int = 7) -> np.ndarray:
    return DISTRIBUTIONS[name](n, np.random.default_rng(seed))


def context_or_skip(backend):
    """The backend's GL context; a machine without it skips, unless BLOCKHASH_REQUIRE_GL
    names the backend (CI installs and requires both)."""
    from blockhash.errors import GLUnavailableError
    from blockhash.gl.context import get_context

    try:
        return get_context(backend)
    except GLUnavailableError as exc:
        if backend in os.environ.get("BLOCKHASH_REQUIRE_GL", "").split(","):
            raise
        pytest.skip(f"{backend} unavailable: {exc}")


@pytest.fixture(autouse=True)
def gl_error_checked():
    """After every test, each GL context it used reports no error: moderngl records GL
    errors in ``ctx.error`` instead of raising, so a test could pass over one."""
    yield
    import sys

    context = sys.modules.get("blockhash.gl.context")
    if context is None:
        return
    for name, ctx in context.open_contexts().items():
        with ctx:
            err = ctx.error
        assert err == "GL_NO_ERROR", f"the {name} context was left with {err}"
