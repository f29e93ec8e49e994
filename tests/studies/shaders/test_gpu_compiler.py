"""The GPU compiler check (blockhash/studies/shaders/gpu_compiler.py, tools/shader_stats.py): Mesa
RADV's ACO backend compiles the shaders blockhash runs on a null RDNA2 device, and the GPU-shaped lookup fits its budget
(no scratch memory, no spills, at most 64 VGPRs in wave64); shaders that do not fit fail.

Skipped where the toolchain (glslang, cc, Vulkan headers, RADV) is missing, unless
BLOCKHASH_REQUIRE_GPU_COMPILER is set (CI sets it, so there it fails instead)."""

import os
from pathlib import Path

import pytest
from conftest import context_or_skip

from blockhash.studies.shaders import gpu_compiler

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)


@pytest.fixture(scope="module", autouse=True)
def toolchain():
    missing = gpu_compiler.available()
    if missing:
        if os.environ.get("BLOCKHASH_REQUIRE_GPU_COMPILER"):
            pytest.fail(f"BLOCKHASH_REQUIRE_GPU_COMPILER is set but {missing}")
        pytest.skip(missing)


#: A local array indexed by a variable: RADV puts it in scratch memory.
INDEXED_ARRAY = """#version 450 core
uniform usampler2D t; uniform int i; out vec4 c;
void main() { uint a[96]; for (int j = 0; j < 96; j++) a[j] = texelFetch(t, ivec2(j, 0), 0).x;
              c = vec4(float(a[i & 95])); }
"""
#: 96 values live across a loop's back edge: about 100 VGPRs, no scratch.
LIVE_VALUES = """#version 450 core
uniform usampler2D t; uniform int rounds; out vec4 c;
void main() {
    uint a[48]; uint b[48];
    for (int j = 0; j < 48; j++) { a[j] = texelFetch(t, ivec2(j, int(gl_FragCoord.y)), 0).x;
                                   b[j] = texelFetch(t, ivec2(j + 48, int(gl_FragCoord.y)), 0).x; }
    for (int r = 0; r < rounds; r++)
        for (int j = 0; j < 48; j++) { a[j] = a[j] * b[(j + 1) % 48] + uint(r); b[j] ^= a[(j + 7) % 48]; }
    uint h = 0u; for (int j = 0; j < 48; j++) h += a[j] + b[j];
    c = vec4(float(h)); }
"""
SMALL = """#version 450 core
uniform sampler2D t; out vec4 c;
void main() { c = texelFetch(t, ivec2(gl_FragCoord.xy), 0) * 2.0; }
"""


@pytest.mark.slow
def test_a_local_array_indexed_by_a_variable_breaks_the_budget():
    stats = gpu_compiler.compile_stats(INDEXED_ARRAY, "navi21")
    assert stats["scratch_lane"] >= 384 and stats["wave"] == 64
    assert any("scratch" in b for b in gpu_compiler.over_budget(stats))


@pytest.mark.slow
def test_many_live_values_break_the_register_budget():
    stats = gpu_compiler.compile_stats(LIVE_VALUES, "navi21")
    assert stats["scratch_lane"] == 0 and stats["preVGPRs"] > 64
    assert [b for b in gpu_compiler.over_budget(stats) if "VGPRs demanded" in b]


@pytest.mark.slow
def test_a_small_shader_fits_on_every_family():
    for family in gpu_compiler.FAMILIES:
        stats = gpu_compiler.compile_stats(SMALL, family)
        assert gpu_compiler.over_budget(stats) == [], (family, stats)
        assert 0 < stats["preVGPRs"] <= 8 and stats["instructions"] > 0


def test_a_shader_glslang_rejects_names_the_error():
    with pytest.raises(RuntimeError, match="glslang rejected the frag shader"):
        gpu_compiler.compile_stats(SMALL.replace("* 2.0", "* undeclared"), "navi21")


@pytest.fixture(scope="module")
def lookups():
    context_or_skip("egl")
    return gpu_compiler.lookup_shaders(50, 8, lookups=("walk", "cells"), kdtree=False,
                                       backend="egl")


@pytest.mark.slow
def test_the_cells_lookup_fits_the_gpu_budget(lookups):
    """k = 50, A = 8, RDNA2 wave64: the lookup and its fetch-only floor."""
    for name in ("lookup cells", "lookup cells fetch-only"):
        stats = gpu_compiler.compile_stats(lookups[name], "navi21")
        assert gpu_compiler.over_budget(stats) == [], (name, stats)


@pytest.mark.slow
def test_the_check_catches_the_walks_scratch_queues(lookups):
    """The walk's 192-entry queues are local arrays indexed by variables."""
    stats = gpu_compiler.compile_stats(lookups["lookup walk"], "navi21")
    assert stats["scratch_lane"] >= 1536
    assert gpu_compiler.over_budget(stats)


@pytest.mark.slow
def test_the_cells_caustic_pass_fits_the_gpu_budget():
    context_or_skip("egl")
    scene = Path(__file__).resolve().parents[3] / "scenes" / "ring.toml"
    shaders = gpu_compiler.caustic_shaders(str(scene), lookups=("cells",), backend="egl")
    assert len(shaders) == 3
    for name, text in shaders.items():
        stats = gpu_compiler.compile_stats(text, "navi21")
        assert gpu_compiler.over_budget(stats) == [], (name, stats)


@pytest.fixture(scope="module")
def ring_caustic_passes():
    context_or_skip("egl")
    scene = Path(__file__).resolve().parents[3] / "scenes" / "ring.toml"
    return gpu_compiler.caustic_shaders(str(scene), lookups=("cover", "walk"), backend="egl")


def test_the_default_caustic_pass_fits_its_gpu_budget(ring_caustic_passes):
    """The cover gather's pass, every stage, RDNA2 wave64: no scratch memory, no spills, at
    most COVER_VGPR_BUDGET (48) VGPRs."""
    cover = {n: t for n, t in ring_caustic_passes.items() if n.startswith("caustic cover")}
    assert len(cover) == 3
    for name, text in cover.items():
        stats = gpu_compiler.compile_stats(text, "navi21")
        assert gpu_compiler.over_budget(stats, gpu_compiler.COVER_VGPR_BUDGET) == [], (name, stats)


def test_the_default_passes_budget_fails_a_pass_that_breaks_it(ring_caustic_passes):
    """The walk's caustic pass (its queues in scratch, 100+ VGPRs) fails the same check."""
    stats = gpu_compiler.compile_stats(ring_caustic_passes["caustic walk: lookup + estimate"],
                                       "navi21")
    broken = gpu_compiler.over_budget(stats, gpu_compiler.COVER_VGPR_BUDGET)
    assert any("scratch" in b for b in broken) and any("VGPRs demanded" in b for b in broken)
