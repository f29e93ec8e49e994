"""The conserving estimate over the cover gather: the shader pass (glsl/caustic_cover.glsl)
against its CPU reference per shading point, the analytic plane, and the default render."""

from pathlib import Path

import numpy as np
import pytest
from conftest import context_or_skip
from test_caustic import FLUX, KD, grid_points

from blockhash import BlockHashIndex
from blockhash.errors import CapacityError, InputError
from blockhash.frame.caustic import CausticPass, estimate_from_neighbours
from blockhash.frame.cover_estimate import cover_gather, estimate_cover_cpu
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.options import LookupOptions, resolve_method

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

N = 60_000
MATS = [((KD, 0.4, 0.3), (0.25, 0.25, 0.25), 20.0)]


@pytest.fixture(scope="module")
def plane_index():
    rng = np.random.default_rng(0)
    pos = np.stack([rng.random(N), rng.normal(0, 1e-4, N), rng.random(N)], axis=1)
    normals = np.tile([0, 1.0, 0], (N, 1))
    normals[::7] = [1.0, 0, 0]  # some photons of a surface facing elsewhere
    dirs = np.tile([0.3, -1.0, 0.1], (N, 1))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    dirs[::11] *= -1  # some from behind
    return BlockHashIndex(pos, k=50, A=8, directions=dirs, normals=normals,
                          powers=rng.uniform(0.5, 1.5, (N, 3)) * FLUX / N)


def test_uniform_photons_on_a_plane_give_the_analytic_radiance():
    rng = np.random.default_rng(0)
    pos = np.stack([rng.random(N), np.zeros(N), rng.random(N)], axis=1)
    index = BlockHashIndex(pos, k=50, directions=np.tile([0, -1.0, 0], (N, 1)),
                           powers=np.full((N, 3), FLUX / N))
    L = estimate_cover_cpu(cover_gather(index, 50), grid_points(), [((KD,) * 3, (0, 0, 0), 1.0)])
    assert L.mean() == pytest.approx(KD * FLUX / np.pi, rel=0.02)


@pytest.mark.parametrize("backend", ["egl", "osmesa"])
@pytest.mark.parametrize("options", [
    EstimateOptions(),
    EstimateOptions(filter="none", normal_cos=None),
    EstimateOptions(filter="silverman", disc=0.5),
    EstimateOptions(filter="epanechnikov", normal_cos=0.9),
], ids=lambda o: o.label)
def test_shader_pass_equals_the_cpu_reference_per_point(plane_index, options, backend):
    context_or_skip(backend)
    pts = grid_points(48, 40, lo=-0.05, hi=1.05, view=(0.6, 0.8, 0.0))
    cpu = estimate_cover_cpu(cover_gather(plane_index, 50), pts, MATS, options)
    gl = CausticPass(plane_index, backend=backend, gather="cover").render(pts, MATS, options=options)
    assert (cpu > 0).mean() > 0.8
    # The same photons per point; float32 sums only.
    np.testing.assert_allclose(gl, cpu, rtol=2e-5, atol=1e-6 * cpu.max())


def test_the_cover_sum_holds_every_photon_the_k_nearest_sum_counts(plane_index):
    """With the k nearest (exact), the conserving estimate sums the covering photons among
    them: a subset, so never more, and here within a few percent."""
    from blockhash.evaluate.metrics import exact_knn
    from blockhash.frame.photon_radius import own_radii2

    pts = grid_points(24, 24)
    cover = estimate_cover_cpu(cover_gather(plane_index, 50), pts, MATS)
    knn = estimate_from_neighbours(plane_index, pts, MATS,
                                   lambda q: exact_knn(plane_index.positions, q, 50), 50,
                                   radii=own_radii2)
    assert (knn <= cover * (1 + 1e-5) + 1e-9).all()
    assert knn.sum() / cover.sum() > 0.97


def test_the_cover_gather_takes_the_conserving_estimate_only(plane_index):
    with pytest.raises(InputError, match="method='bh'"):
        resolve_method("cover", "unbiased")
    assert resolve_method("auto", "conserving") == "cover"
    assert resolve_method("auto", "paper") == "bh"
    assert LookupOptions().method == "auto"
    with pytest.raises(InputError, match="needs the k nearest"):
        CausticPass(plane_index, gather="cover").render(
            grid_points(4, 4), MATS, options=EstimateOptions(estimate="unbiased"))


@pytest.mark.parametrize("axes", [(0, 1, 2), (1, 0, 2), (2, 0, 1), (0, 2, 1)])
def test_the_shader_reads_the_windows_of_every_fine_axis(plane_index, axes):
    """The plane turned so that the fine axis (cover.py fine_axis) is each of x, y and z:
    the shader's axis order and window keys give the CPU reference's sum per point."""
    context_or_skip("egl")
    from blockhash.frame.shading_points import ShadingPoints

    axes = list(axes)
    rec, slot = plane_index.records, plane_index.slot_of
    index = BlockHashIndex(plane_index.positions[:, axes], k=50,
                           directions=rec.directions()[slot][:, axes],
                           normals=rec.normals()[slot][:, axes], powers=rec.powers()[slot, :3])
    base = grid_points(32, 24, lo=-0.05, hi=1.05, view=(0.6, 0.8, 0.0))
    pts = ShadingPoints(base.position[..., axes], base.normal[..., axes], base.view[..., axes],
                        base.material, base.weight)
    gather = cover_gather(index, 50)
    assert gather.axis == axes.index(2)  # the plane's photons mostly face +y, some +x
    cpu = estimate_cover_cpu(gather, pts, MATS)
    gl = CausticPass(index, backend="egl", gather="cover").render(pts, MATS)
    assert (cpu > 0).mean() > 0.8
    np.testing.assert_allclose(gl, cpu, rtol=2e-5, atol=1e-6 * cpu.max())


def test_a_pile_past_llvmpipes_loop_limit_is_refused_there():
    """Photons piled at one point fill one cell; past llvmpipe's loop limit the pass refuses
    (it would silently stop there), naming the limit and the way out."""
    ctx = context_or_skip("egl")
    from blockhash.gl.limits import is_llvmpipe

    if not is_llvmpipe(ctx):
        pytest.skip("the loop limit is llvmpipe's")
    pos = np.vstack([np.zeros((70_000, 3)), np.random.default_rng(1).random((100, 3))])
    with pytest.warns(UserWarning):  # the pile is also beyond the k-nearest index's buckets
        index = BlockHashIndex(pos, k=8)
    with pytest.raises(CapacityError, match=r"65,535.*method='cpu'"):
        CausticPass(index, backend="egl", gather="cover").render(grid_points(2, 2), MATS)


@pytest.fixture(scope="module")
def ring_scene_points():
    """The ring's camera points at 40 x 40 (one per pixel) and 40,000 of its photons."""
    from blockhash.frame.gbuffer import rasterize
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.frame.shading import shading_points
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.scene.loader import load_scene
    from blockhash.scene.materials import receiver_materials
    from blockhash.scene.model import MirrorMaterial

    context_or_skip("egl")
    scene = load_scene(Path(__file__).resolve().parents[2] / "scenes" / "ring.toml")
    scene = scene.with_size(40, 40)
    pm = trace_caustic_photons(scene, 40_000, seed=1)
    index = BlockHashIndex(pm.positions, k=50, directions=pm.directions, normals=pm.normals,
                           powers=pm.powers)
    g = rasterize(scene.camera, scene.objects, backend="egl")
    pts = shading_points(scene.camera, g, scene.objects, SceneRays(scene.objects), (MirrorMaterial,))
    return scene, index, pts, receiver_materials(scene.objects)


def test_splatting_equals_the_gather_where_the_camera_sees_the_receiver(ring_scene_points):
    """The same estimate scattered: equal to the cover gather's per pixel that sees a receiver
    directly; where the pixel sees the floor in the mirror ring, only the photons that project
    near it (by the ring's foot, where the floor and its image meet) reach it."""
    from blockhash.studies.shaders.splat_pass import SplatPass

    scene, index, pts, mats = ring_scene_points
    gather = cover_gather(index, 50)
    splat, walls = SplatPass(gather, backend="egl").render(pts, mats, scene.camera, repeat=2)
    cover = CausticPass(index, backend="egl", gather="cover").render(pts, mats)
    direct = (pts.material >= 0) & (pts.weight == 1).all(axis=2)
    assert len(walls) == 2 and (cover[direct] > 0).mean() > 0.3
    np.testing.assert_allclose(splat[direct], cover[direct], rtol=2e-5, atol=1e-6 * cover.max())
    seen_in_mirror = (pts.material >= 0) & ~direct
    assert seen_in_mirror.any() and cover[seen_in_mirror].sum() > 0
    assert splat[seen_in_mirror].sum() < 0.3 * cover[seen_in_mirror].sum()


def test_hostile_photons_and_points_stay_finite_and_equal_the_cpu(gl_mode):
    """In strict GL too (poisoned textures, undefined operations NaN): a diffuse receiver
    (exponent 0: pow(0, 0)) beside a glossy one, zero-power photons, a pile of identical
    photons (zero own radii), shading points far from every photon (empty windows) and on the
    photons' cell borders (the windows' edges)."""
    context_or_skip("egl")
    from blockhash.frame.shading_points import ShadingPoints

    rng = np.random.default_rng(4)
    n = 4_000
    pos = np.stack([rng.random(n), np.zeros(n), rng.random(n)], axis=1)
    pos[:200] = (0.5, 0.0, 0.5)  # a pile: its photons' own radii are 0
    powers = rng.uniform(0.5, 1.5, (n, 3)) * FLUX / n
    powers[::5] = 0.0  # zero-power photons
    dirs = np.tile([0.3, -1.0, 0.1], (n, 1)) / np.sqrt(1.1)
    index = BlockHashIndex(pos, k=50, A=8, directions=dirs, powers=powers)
    gather = cover_gather(index, 50)
    # Far points beyond [0, 1]; seen from a grazing direction away from the photons' mirror
    # direction, so that the Phong lobe's cosine is 0.
    base = grid_points(24, 24, lo=-0.5, hi=1.5, view=(-0.99, 0.141, 0.0))
    position = base.position.copy()
    position[:4, :, 0] = np.float32(0.5)  # rows through the pile, on a cell border of x
    position[4:8, :, 0] = np.float32(index.positions[1000, 0])  # on a photon's own x
    material = np.zeros((24, 24), np.int32)
    material[:, ::2] = 1  # every other column diffuse (ks = 0, exponent 0)
    pts = ShadingPoints(position, base.normal, base.view, material, base.weight)
    mats = [MATS[0], ((KD,) * 3, (0.0, 0.0, 0.0), 0.0)]
    cpu = estimate_cover_cpu(gather, pts, mats)
    gl = CausticPass(index, backend="egl", gather="cover").render(pts, mats)
    assert np.isfinite(gl).all() and (cpu > 0).any() and (cpu == 0).any()
    np.testing.assert_allclose(gl, cpu, rtol=2e-5, atol=1e-6 * cpu.max())
