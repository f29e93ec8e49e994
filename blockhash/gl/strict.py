"""Strict GL: llvmpipe made to see what a GPU's driver may do with undefined operations.

llvmpipe zeroes memory that nobody wrote and computes GLSL's undefined cases in its own way
(``pow(0.0, 0.0)`` is 1 there); NVIDIA's driver leaves memory as it was and computes ``pow(x,
y)`` as ``exp2(y * log2(x))``, so ``pow(0, 0)`` is NaN there.  A render that is finite on llvmpipe
may then be NaN on a GPU.  Strict mode (``BLOCKHASH_GL_STRICT=1`` in the environment, which
worker processes inherit, or :func:`strict` around the code) makes both visible here:

- every shader compiled (:func:`blockhash.gl.shaderlib.compile_program`) gets NaN where GLSL
  leaves ``pow``, ``normalize``, ``sqrt`` and ``inversesqrt`` undefined (``pow(x, y)`` for x < 0
  or x = 0 with y <= 0, the zero vector, a negative or zero argument: :data:`PROLOGUE`);
- every texture the renderer allocates or takes from its pool is filled with NaN's bits
  (``0x7FC00000`` in every channel, float or integer) before its data is written
  (:func:`poison`), so a read past what a pass wrote returns NaN or a huge index, not a zero.

The tests render with it on (tests/gl/test_strict.py); a render's results must stay finite
and equal to the ordinary ones within float rounding.
"""

from __future__ import annotations

import os
from contextlib import contextmanager

import numpy as np

#: The environment variable that turns strict mode on ("1") in this process and its workers.
ENV = "BLOCKHASH_GL_STRICT"
#: NaN's bits (a quiet NaN as float32; a huge count or index as uint32).
POISON = 0x7FC00000

#: GLSL after ``#version``: the library's undefined operations give NaN, as on a GPU.  (Not
#: ``exp2(y * log2(x))`` written out: Mesa's compiler folds that back into its own ``pow``.)
PROLOGUE = """\
// strict GL (blockhash/gl/strict.py): what GLSL leaves undefined is NaN, as on a GPU
float bh_strict_nan() { return uintBitsToFloat(0x7FC00000u); }
float bh_strict_pow(float x, float y) {
    return (x < 0.0 || (x == 0.0 && y <= 0.0)) ? bh_strict_nan() : pow(x, y);
}
vec3 bh_strict_pow(vec3 x, vec3 y) {
    return vec3(bh_strict_pow(x.x, y.x), bh_strict_pow(x.y, y.y), bh_strict_pow(x.z, y.z));
}
vec2 bh_strict_normalize(vec2 v) { return dot(v, v) > 0.0 ? normalize(v) : vec2(bh_strict_nan()); }
vec3 bh_strict_normalize(vec3 v) { return dot(v, v) > 0.0 ? normalize(v) : vec3(bh_strict_nan()); }
float bh_strict_sqrt(float x) { return x < 0.0 ? bh_strict_nan() : sqrt(x); }
float bh_strict_inversesqrt(float x) { return x <= 0.0 ? bh_strict_nan() : inversesqrt(x); }
#define pow(x, y) bh_strict_pow(x, y)
#define normalize(v) bh_strict_normalize(v)
#define sqrt(x) bh_strict_sqrt(x)
#define inversesqrt(x) bh_strict_inversesqrt(x)
"""


def enabled() -> bool:
    """Whether strict mode is on (:data:`ENV` is "1")."""
    return os.environ.get(ENV, "") == "1"


@contextmanager
def strict(on: bool = True):
    """Strict mode on (or off) inside the block, here and in the worker processes it starts."""
    old = os.environ.get(ENV)
    os.environ[ENV] = "1" if on else "0"
    try:
        yield
    finally:
        if old is None:
            del os.environ[ENV]
        else:
            os.environ[ENV] = old


def prologue() -> str:
    """What :func:`blockhash.gl.shaderlib.compile_program` puts after the defines: the strict
    operations when strict mode is on, else nothing."""
    return PROLOGUE if enabled() else ""


def poison(tex) -> None:
    """Fill ``tex`` (a moderngl texture, its context current) with :data:`POISON` in every
    channel, when strict mode is on; its owner then writes what it holds."""
    if not enabled():
        return
    width, height = tex.size
    bits = {4: (POISON, np.uint32), 2: (0x7E00, np.uint16), 1: (0xFF, np.uint8)}  # NaN's bits
    value, dtype = bits[int(tex.dtype[1:])]
    tex.write(np.full((height, width, tex.components), value, dtype=dtype))
