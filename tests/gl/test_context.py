"""The after-test GL error check (conftest's ``gl_error_checked``) sees what moderngl leaves
pending, and ``check_gl`` turns it into an error naming the step."""

import pytest
from conftest import context_or_skip, pending_gl_errors

from blockhash.errors import BlockHashError
from blockhash.gl.context import backend_of, check_gl

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)


def leave_an_error_pending(ctx):
    """An invalid enum passed straight to glBlendFunc: GL records GL_INVALID_ENUM, and
    moderngl raises nothing."""
    with ctx:
        ctx.blend_func = (0xFFFF, 0xFFFF)


@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_the_after_test_check_sees_a_pending_gl_error(backend):
    ctx = context_or_skip(backend)
    assert pending_gl_errors() == {}
    leave_an_error_pending(ctx)
    assert pending_gl_errors() == {backend_of(ctx): "GL_INVALID_ENUM"}
    assert pending_gl_errors() == {}  # reading the error cleared it


def test_check_gl_names_the_step_of_a_pending_error():
    ctx = context_or_skip("egl")
    leave_an_error_pending(ctx)
    with ctx, pytest.raises(BlockHashError, match="GL_INVALID_ENUM.*after the probe"):
        check_gl(ctx, "the probe")
    assert pending_gl_errors() == {}
