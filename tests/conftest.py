"""Shared fixtures: seeded generators, small photon sets, GL contexts."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from plane_scene import plane  # noqa: F401 (the analytic plane scene, a fixture of the render's tests)

from blockhash.evaluate.datasets import DISTRIBUTIONS
from blockhash.studies.reference_cache import CACHE_ENV

#: Mitsuba's renders of the files the reference tests compare against, kept with the tests
#: (blockhash/studies/reference_cache.py): a run renders only what changed, and keeps it here
#: (commit the new files; delete the folder to render them all again).
os.environ.setdefault(CACHE_ENV, str(Path(__file__).resolve().parent / "data" / "mitsuba_cache"))


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


def pending_gl_errors() -> dict[str, str]:
    """The GL error each open context holds, by backend (reading it clears it)."""
    context = sys.modules.get("blockhash.gl.context")
    if context is None:
        return {}
    errors = {}
    for name, ctx in context.open_contexts().items():
        with ctx:
            err = ctx.error
        if err != "GL_NO_ERROR":
            errors[name] = err
    return errors


@pytest.fixture(autouse=True)
def gl_error_checked():
    """After every test, each GL context it used reports no error: moderngl records GL
    errors in ``ctx.error`` instead of raising, so a test could pass over one."""
    yield
    errors = pending_gl_errors()
    assert not errors, f"GL contexts were left with errors: {errors}"


# --------------------------------------------------------------------------- shared cases
# Photon sets and scenes more than one test module uses.

def two_patches_and_far_points(n=30_000, m=400):
    """Photons on two small patches, at opposite corners of the unit square and on the planes
    z = 0 and z = 1; shading points anywhere on the plane z = 0.5 between them, most of them
    far from every photon (the code path of such a point leads to buckets far from it)."""
    rng = np.random.default_rng(3)
    pts = np.zeros((n, 3))
    pts[:, :2] = rng.random((n, 2)) * 0.1
    pts[n // 2:] += (0.9, 0.9, 1.0)
    q = np.full((m, 3), 0.5, dtype=np.float32)
    q[:, :2] = rng.random((m, 2))
    return pts, q


#: Lambertian receivers and known photon sets of the density estimate's tests.
KD = 0.5
LAMBERT = [((KD,) * 3, (0, 0, 0), 1.0)]
DOWN = (0.0, -0.6, -0.8)  # photons travel down and toward -z: they face a floor and a +z wall


def floor_points(h=24, w=24, *, z=(0.2, 0.8), y=0.0, view=(0, 1, 0)):
    from blockhash.frame.shading_points import ShadingPoints

    gx, gz = np.meshgrid(np.linspace(0.05 if w > 32 else 0.2, 0.95 if w > 32 else 0.8, w),
                         np.linspace(*z, h))
    return ShadingPoints(
        position=np.stack([gx, np.full_like(gx, y), gz], axis=2).astype(np.float32),
        normal=np.tile(np.float32([0, 1, 0]), (h, w, 1)), view=np.tile(np.float32(view), (h, w, 1)),
        material=np.zeros((h, w), np.int32), weight=np.ones((h, w, 3), np.float32))


def surfaces(parts, k, seed=0):
    """An index over uniform photons on axis-aligned unit squares: [(n, axis fixed, value,
    normal)], 1 W in total per square."""
    from blockhash import BlockHashIndex

    rng = np.random.default_rng(seed)
    pos, nrm, pw = [], [], []
    for n, axis, value, normal in parts:
        p = rng.random((n, 3))
        p[:, axis] = value
        pos.append(p)
        nrm.append(np.tile(normal, (n, 1)))
        pw.append(np.full((n, 3), 1.0 / n))
    pos = np.concatenate(pos)
    return BlockHashIndex(pos, k=k, A=8, directions=np.tile(DOWN, (len(pos), 1)) / np.linalg.norm(DOWN),
                          normals=np.concatenate(nrm).astype(float), powers=np.concatenate(pw))


FLOOR = (0.0, 1.0, 0.0)


RING_TEMPLATE = """
[camera]
eye = {eye}
target = {target}
fov_y_deg = 38.0
width = 16
height = 16

[materials.floor]
kind = "phong"
kd = 0.55
ks = 0.25
n = 20.0

[materials.mirror]
kind = "mirror"
reflectance = [0.95, 0.78, 0.45]

[[lights]]
kind = "point"
position = {light}
power = 100.0

[[objects]]
name = "floor"
material = "floor"
[objects.shape]
kind = "rectangle"
x = [-1.5, 1.5]
z = [-1.5, 1.5]

{ring}
[photons]
count = 3000
k = 8
A = 4
seed = 1
"""

RING_OBJECT = """
[[objects]]
name = "ring"
material = "mirror"
[objects.shape]
kind = "ring"
inner_radius = 0.50
outer_radius = 0.53
height = 0.30
segments = 64
"""


def small_ring_scene(*, eye="[0.0, 1.9, 1.6]", target="[0.0, 0.0, 0.05]", light="[-2.0, 1.0, 0.0]",
                     ring=RING_OBJECT):
    """The ring scene at 16 x 16 with 3,000 photons (k = 8, A = 4), its placement given."""
    from blockhash.scene.loader import parse_scene

    return parse_scene(RING_TEMPLATE.format(eye=eye, target=target, light=light, ring=ring))


TOOLS_DIR = Path(__file__).resolve().parents[1] / "tools"


def run_tool(name: str, args, cwd, *, timeout=600) -> str:
    """``tools/NAME`` run with ``args`` from ``cwd`` (a folder outside the checkout: tools find
    the scenes beside themselves); its stdout, after asserting it exited 0."""
    run = subprocess.run([sys.executable, str(TOOLS_DIR / name), *map(str, args)], cwd=cwd,
                         capture_output=True, text=True, timeout=timeout)
    assert run.returncode == 0, f"{name} exited {run.returncode}:\n{run.stderr[-3000:]}"
    return run.stdout


def mitsuba_or_skip():
    """Skip without Mitsuba 3 (the extra blockhash[mitsuba]), unless BLOCKHASH_REQUIRE_MITSUBA
    is set (CI sets it), where it fails instead."""
    from blockhash.reference.mitsuba import mitsuba_available

    ok, why = mitsuba_available()
    if not ok:
        if os.environ.get("BLOCKHASH_REQUIRE_MITSUBA"):
            pytest.fail(f"BLOCKHASH_REQUIRE_MITSUBA is set but {why}")
        pytest.skip(why)


@pytest.fixture(params=["plain", "strict"])
def gl_mode(request):
    """Each test that takes it runs twice: as usual, and in strict GL (blockhash/gl/strict.py:
    textures poisoned with NaN before they are written, GLSL's undefined operations NaN, as a
    GPU may give them), where its results must hold as well."""
    from blockhash.gl.strict import strict

    with strict(request.param == "strict"):
        yield request.param


def roughened(scene, alpha: float, distribution: str):
    """``scene`` with its mirrors and glass rough (:mod:`blockhash.scene.microfacet`)."""
    from dataclasses import replace

    objects = tuple(replace(o, material=replace(o.material, alpha=alpha,
                                                distribution=distribution))
                    if o.is_specular else o for o in scene.objects)
    return replace(scene, objects=objects)
