"""Caustic radiance: the shader pass against its CPU reference, and an analytic plane."""

import numpy as np
import pytest

from blockhash import BlockHashIndex
from blockhash.evaluate.testing import assert_images_close
from blockhash.frame.caustic import CausticPass, estimate_cpu
from blockhash.frame.shading_points import ShadingPoints
from blockhash.scene.materials import phong_brdf

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

N = 100_000
FLUX = 10.0  # watts over the unit square
KD = 0.5


@pytest.fixture(scope="module")
def plane_index():
    rng = np.random.default_rng(0)
    pos = np.stack([rng.random(N), np.zeros(N), rng.random(N)], axis=1)
    return BlockHashIndex(pos, k=50, A=8, directions=np.tile([0, -1.0, 0], (N, 1)),
                          powers=np.full((N, 3), FLUX / N))


def grid_points(h=32, w=32, *, lo=0.2, hi=0.8, normal=(0, 1, 0), view=(0, 1, 0)):
    gx, gz = np.meshgrid(np.linspace(lo, hi, w), np.linspace(lo, hi, h))
    return ShadingPoints(
        position=np.stack([gx, np.zeros_like(gx), gz], axis=2).astype(np.float32),
        normal=np.tile(np.float32(normal), (h, w, 1)), view=np.tile(np.float32(view), (h, w, 1)),
        material=np.zeros((h, w), np.int32), weight=np.ones((h, w, 3), np.float32))


def test_uniform_photons_on_a_plane_give_the_analytic_radiance(plane_index):
    # Irradiance E = FLUX / area = 10 W/m^2; a Lambertian kd gives L = kd E / pi.  The
    # default (conserving) estimate spreads each photon over its own disc, which reaches
    # its 36th nearest photon at k = 50: relative noise about sqrt(1.5 / 36) = 20 % per
    # pixel with the cone filter (tests/frame/test_photon_radius.py), 0.9 % over 1,024 pixels
    # whose discs overlap a few times over.
    L = estimate_cpu(plane_index, grid_points(), [((KD,) * 3, (0, 0, 0), 1.0)])
    expected = KD * FLUX / np.pi
    assert L.mean() == pytest.approx(expected, rel=0.015)
    assert np.std(L[..., 0]) / expected < 0.3


def test_photons_from_behind_the_surface_are_ignored(plane_index):
    L = estimate_cpu(plane_index, grid_points(normal=(0, -1, 0)), [((KD,) * 3, (0, 0, 0), 1.0)])
    assert np.all(L == 0)


@pytest.mark.parametrize("variant", ["default", "paper", "binary-branch-on-network"])
def test_shader_pass_equals_the_cpu_reference(plane_index, variant, tmp_path):
    mats = [((KD, 0.4, 0.3), (0.25, 0.25, 0.25), 20.0)]
    pts = grid_points(view=(0.6, 0.8, 0.0))
    cpu = estimate_cpu(plane_index, pts, mats, variant=variant)
    gl = CausticPass(plane_index, backend="egl").render(pts, mats, variant=variant)
    # Same photons, same neighbours: float32 rounding only (docs/image-tests.md).
    assert_images_close(gl, cpu, max_rel_rms=1e-4, out_dir=tmp_path)


def test_background_pixels_stay_black(plane_index):
    pts = grid_points()
    pts.material[:4] = -1
    gl = CausticPass(plane_index, backend="egl").render(pts, [((KD,) * 3, (0, 0, 0), 1.0)])
    assert np.all(gl[:4] == 0) and np.all(gl[4:] > 0)


def test_modified_phong_is_energy_conserving_and_peaks_at_the_mirror_direction():
    rng = np.random.default_rng(3)
    n = np.tile([0, 0, 1.0], (200_000, 1))
    wi = np.tile([0.3, 0, np.sqrt(1 - 0.09)], (200_000, 1))
    u = rng.random((200_000, 2))  # uniform hemisphere
    z = u[:, 0]
    r = np.sqrt(1 - z * z)
    wo = np.stack([r * np.cos(2 * np.pi * u[:, 1]), r * np.sin(2 * np.pi * u[:, 1]), z], axis=1)
    kd, ks, e = np.full((1, 3), 0.55), np.full((1, 3), 0.25), np.full(200_000, 20.0)
    f = phong_brdf(wi, wo, n, kd, ks, e)
    albedo = (f[:, 0] * z).mean() * 2 * np.pi  # integral of f cos over the hemisphere
    assert albedo <= 0.55 + 0.25 + 0.01
    mirror = np.array([[-0.3, 0, np.sqrt(1 - 0.09)]])
    peak = phong_brdf(wi[:1], mirror, n[:1], kd, ks, e[:1])
    assert peak[0, 0] == pytest.approx(0.55 / np.pi + 0.25 * 22 / (2 * np.pi))


@pytest.mark.gl
def test_point_textures_hold_each_point_bottom_row_first():
    """The pass reads point (row, col) at GL row h - 1 - row: position and material id,
    normal and 1, view and 0, every value as given."""
    from conftest import context_or_skip

    from blockhash.frame.caustic import point_textures

    ctx = context_or_skip(None)
    rng = np.random.default_rng(1)
    h, w = 7, 11
    pts = ShadingPoints(position=rng.random((h, w, 3), dtype=np.float32),
                        normal=rng.random((h, w, 3), dtype=np.float32),
                        view=rng.random((h, w, 3), dtype=np.float32),
                        material=rng.integers(-1, 5, (h, w)).astype(np.int32),
                        weight=np.ones((h, w, 3), np.float32))
    with ctx:
        got = [np.frombuffer(t.read(), np.float32).reshape(h, w, 4)[::-1]
               for t in point_textures(ctx, pts)]
    fourths = (pts.material.astype(np.float32), np.ones((h, w)), np.zeros((h, w)))
    for texture, xyz, fourth in zip(got, (pts.position, pts.normal, pts.view), fourths):
        np.testing.assert_array_equal(texture[..., :3], xyz)
        np.testing.assert_array_equal(texture[..., 3], fourth)
