"""Shading points inside pixels (blockhash.frame.subpixel) and the done-when check's
pixel means (blockhash.studies.density.sampling)."""

from pathlib import Path

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.frame.subpixel import raycast_gbuffer, subpixel_points
from blockhash.scene.camera import Pinhole
from blockhash.scene.loader import load_scene

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

SCENES = Path(__file__).resolve().parents[2] / "scenes"


@pytest.mark.parametrize("seed", [None, 3])
def test_each_point_lies_in_its_pixel_and_each_cell_holds_one(seed):
    w, h, s = 7, 5, 3
    x, y = subpixel_points(w, h, s, seed)
    assert x.shape == y.shape == (h * s, w * s)
    # point (row * s + i, col * s + j) in pixel (row, col) ...
    np.testing.assert_array_equal(np.floor(x), np.repeat(np.arange(w), s)[None, :].repeat(h * s, 0))
    np.testing.assert_array_equal(np.floor(y), np.repeat(np.arange(h), s)[:, None].repeat(w * s, 1))
    # ... and in its own cell of 1/s x 1/s: one point per cell, every cell once
    np.testing.assert_array_equal(np.floor(x * s), np.arange(w * s)[None, :].repeat(h * s, 0))
    np.testing.assert_array_equal(np.floor(y * s), np.arange(h * s)[:, None].repeat(w * s, 1))


def test_regular_points_are_cell_centres_and_jitter_is_the_same_per_seed():
    x, y = subpixel_points(2, 1, 2)
    np.testing.assert_array_equal(x, [[0.25, 0.75, 1.25, 1.75]] * 2)
    np.testing.assert_array_equal(y, [[0.25] * 4, [0.75] * 4])
    a, b, c = (subpixel_points(9, 4, 4, seed) for seed in (5, 5, 6))
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.allclose(a[0], c[0])
    # jitter moves the points off the centres by less than half a cell
    centre = subpixel_points(9, 4, 4)
    assert 0 < np.abs(a[0] - centre[0]).max() <= 0.5 / 4


def test_a_subset_of_pixels_gets_the_same_cells():
    px = np.array([[2, 3], [0, 0], [4, 6]])
    s = 4
    x, y = subpixel_points(7, 5, s, pixels=px)
    fx, fy = subpixel_points(7, 5, s)
    assert x.shape == (3 * s, s)
    for p, (row, col) in enumerate(px):
        np.testing.assert_array_equal(x[p * s:(p + 1) * s], fx[row * s:(row + 1) * s, col * s:(col + 1) * s])
        np.testing.assert_array_equal(y[p * s:(p + 1) * s], fy[row * s:(row + 1) * s, col * s:(col + 1) * s])
    xj, yj = subpixel_points(7, 5, s, 11, pixels=px)
    for p, (row, col) in enumerate(px):
        assert (np.floor(xj[p * s:(p + 1) * s]) == col).all() and (np.floor(yj[p * s:(p + 1) * s]) == row).all()
        np.testing.assert_array_equal(np.floor(xj[p * s:(p + 1) * s] * s) - col * s, np.tile(np.arange(s), (s, 1)))
    with pytest.raises(InputError, match="inside the 7 x 5 image"):
        subpixel_points(7, 5, 2, pixels=[[5, 0]])
    with pytest.raises(InputError, match="samples"):
        subpixel_points(7, 5, 0)


def test_film_points_project_into_the_pixel_the_reference_counts_them_in():
    scene = load_scene(SCENES / "ring.toml")
    pin = Pinhole.of(scene.camera, (13, 9))
    x, y = subpixel_points(13, 9, 3, 2)
    pix, _ = pin.project(pin.eye + 1.7 * pin.film_rays(x, y))
    np.testing.assert_array_equal(pix, (np.floor(y) * 13 + np.floor(x)).ravel().astype(np.int64))


def test_jitter_integrates_a_thin_line_where_a_regular_grid_aliases():
    # a line 0.1 pixel wide at x = 3.37: its mean over pixel column 3 is 0.1
    def line(x):
        return (np.abs(x - 3.37) < 0.05).astype(float)

    s = 4
    regular = line(subpixel_points(6, 2, s)[0])[:, 3 * s:4 * s].mean()
    assert regular == pytest.approx(0.25)  # the column of cell centres at 3.375 is on the line
    means = [line(subpixel_points(6, 2, s, seed)[0])[:, 3 * s:4 * s].mean() for seed in range(400)]
    assert np.mean(means) == pytest.approx(0.1, abs=4 * np.std(means) / np.sqrt(len(means)))


def test_cell_centres_by_ray_casting_see_what_the_rasteriser_sees():
    from conftest import context_or_skip

    context_or_skip("egl")
    from blockhash.frame.gbuffer import rasterize
    from blockhash.frame.scene_rays import SceneRays

    scene = load_scene(SCENES / "ring.toml")
    g = rasterize(scene.camera, scene.objects, size=(64, 48), backend="egl")
    c = raycast_gbuffer(scene.camera, SceneRays(scene.objects), size=(32, 24), samples=2)
    assert c.object.shape == g.object.shape == (48, 64)
    same = c.object == g.object
    assert same.mean() > 0.98  # silhouettes may differ by a sample
    both = same & (g.object >= 0)
    scale = np.linalg.norm(scene.camera.eye - scene.camera.target)
    assert np.abs(c.position[both] - g.position[both]).max() < 1e-3 * scale
    assert np.median(np.einsum("ij,ij->i", c.normal[both], g.normal[both])) > 0.9999


@pytest.mark.parametrize("aperture", [0.0, 0.05])
def test_the_film_is_cast_in_chunks_the_same_as_at_once(monkeypatch, aperture):
    """Chunks of 7 rays (a short last one, a film's misses, glass's back faces and a lens)
    give the G-buffer one cast of every ray gives, bit for bit."""
    from dataclasses import replace

    from blockhash.frame import subpixel
    from blockhash.frame.scene_rays import SceneRays

    scene = load_scene(SCENES / "glass.toml")
    camera = replace(scene.camera, aperture_radius=aperture, focus_distance=2.0)
    rays, pin = SceneRays(scene.objects), Pinhole.of(camera, (19, 13))
    x, y = subpixel_points(pin.width, pin.height, 2, 3)
    whole = subpixel.film_gbuffer(pin, rays, x, y)
    monkeypatch.setattr(subpixel, "CHUNK_RAYS", 7)
    chunks = subpixel.film_gbuffer(pin, rays, x, y)
    assert (whole.object < 0).any() and (whole.object >= 0).any() and not whole.front.all()
    for name in ("position", "normal", "object", "front", "origin"):
        a, b = getattr(whole, name), getattr(chunks, name)
        if name == "origin":
            assert (a is None) == (b is None) == (aperture == 0)
        if a is not None:
            assert a.dtype == b.dtype and np.array_equal(a, b), name


def test_estimate_images_in_chunks_equal_one_search_and_only_fill_what_was_asked():
    from conftest import FLOOR, LAMBERT, floor_points, surfaces

    from blockhash.frame.caustic import Neighbours
    from blockhash.frame.estimate import EstimateOptions
    from blockhash.studies.density.estimates import estimate_images

    index = surfaces([(4000, 1, 0.0, FLOOR)], k=10)
    pts = floor_points(12, 10)
    opts = [EstimateOptions(), EstimateOptions(estimate="paper", filter="none", normal_cos=None)]
    search = index.query
    whole = [Neighbours.find(index, pts, search, 10, own=opts).estimate(LAMBERT, o) for o in opts]
    chunked = estimate_images(index, pts, LAMBERT, search, 10, opts, chunk=17)
    for a, b in zip(whole, chunked):
        np.testing.assert_array_equal(a, b)
    only = np.zeros((12, 10), bool)
    only[3:5, 2:9] = True
    part = estimate_images(index, pts, LAMBERT, search, 10, opts, only=only)
    np.testing.assert_array_equal(part[0][only], whole[0][only])
    assert not part[0][~only].any()


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    from blockhash.studies.density.sampling import done_when_study

    return done_when_study(load_scene(SCENES / "corner.toml"), photons=3_000, ks=(20,), size=(24, 24),
                           samples=2, seeds=(1, 2, 3), refine=5, refine_samples=4,
                           reference_photons=200_000, cache_dir=tmp_path_factory.mktemp("cache"),
                           progress=lambda s: None)


def test_done_when_study_rows_summary_and_tables(small_study):
    from blockhash.studies.density.sampling import context_table, done_when_table, options, summary

    rows = small_study["rows"]
    labels = [o.label for o in options()]
    for seed in (None, 1, 2, 3, "mean"):
        assert [r["option"] for r in rows if r["seed"] == seed] == labels
    assert all(r["refined"] == 5 for r in rows if r["seed"] in (1, 2, 3))
    assert all(r["refined"] == 0 for r in rows if r["seed"] is None)
    s = {x["option"]: x for x in summary(small_study)}
    default = s[labels[1]]
    assert default["n_seeds"] == 3 and np.isfinite([default["flux"], default["flux_se"],
                                                     default["blur_region"], default["blur_region_se"]]).all()
    fluxes = [r["flux"] for r in rows if r["seed"] in (1, 2, 3) and r["option"] == labels[1]]
    assert default["flux"] == pytest.approx(np.mean(fluxes))
    assert default["regular"] is not None and default["pooled"] is not None
    # the map's own photons carry the reference's flux: the light tracer's splat of as many
    # photons as the map emitted (about 3,500) spreads by 0.064 over seeds (12 seeds, measured)
    assert 0.75 < small_study["splat"]["flux"] < 1.25
    table = done_when_table([small_study])
    assert "| corner | 20 | bh | **default** |" in table and "| corner | 20 | bh | paper |" in table
    assert "8 x 8" not in context_table([small_study]) and "2 x 2 jittered" in context_table([small_study])


def test_refinement_replaces_only_the_most_uneven_pixels_with_fresh_points():
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.index.block_hash_index import BlockHashIndex
    from blockhash.photons.tracing import trace_caustic_photons
    from blockhash.reference.lighttrace import lambertian
    from blockhash.scene.materials import receiver_materials
    from blockhash.studies.density.sampling import options, pixel_means, refine_seed

    scene = lambertian(load_scene(SCENES / "ring.toml"))
    pm = trace_caustic_photons(scene, 5_000, seed=1)
    index = BlockHashIndex(pm.positions, k=20, A=8, directions=pm.directions, normals=pm.normals,
                           powers=pm.powers)
    rays = SceneRays(scene.objects)
    mask = np.ones((20, 20), bool)
    args = (scene, index, rays, receiver_materials(scene.objects), index.query, 20, options(), mask)
    plain, n0 = pixel_means(*args, size=(20, 20), samples=3, seed=4, refine=0)
    refined, n = pixel_means(*args, size=(20, 20), samples=3, seed=4, refine=7, refine_samples=6)
    assert n0 == 0 and n == 7
    changed = np.any(plain[1] != refined[1], axis=2)
    assert 0 < changed.sum() <= 7
    # the refined pixels were the most uneven ones, so they are among the caustic's
    assert refined[1][changed].sum() > 0
    assert refine_seed(4) == refine_seed(4) != refine_seed(5) and refine_seed(4) != 4


@pytest.mark.slow
def test_the_study_tool_prints_the_done_when_tables_again_from_its_json(small_study, tmp_path):
    import json
    import subprocess
    import sys

    path = tmp_path / "study.json"
    path.write_text(json.dumps([small_study]))
    tool = Path(__file__).resolve().parents[2] / "tools" / "estimate_study.py"
    if not tool.is_file():
        pytest.skip("tools/ is not beside the package (installed wheel)")
    out = subprocess.run([sys.executable, str(tool), "--done-when", "--from-json", str(path)],
                         capture_output=True, text=True, check=True).stdout
    assert "| corner | 20 | bh | **default** |" in out and "What the rows rest on" in out


@pytest.mark.slow
def test_the_k_nearest_estimate_adds_flux_at_a_fold_and_less_with_more_photons():
    from blockhash.studies.density import fold_bias as fold

    few = fold.flux_ratio("fold", 20_000, 50, ["none", "cone"], points=400)
    many = fold.flux_ratio("fold", 320_000, 50, ["none", "cone"], points=400)
    smooth = fold.flux_ratio("smooth", 20_000, 50, ["cone"], points=400)
    assert few["none"] > few["cone"] > 1.01 and 1.0 < many["cone"] < few["cone"]
    assert abs(smooth["cone"] - 1.0) < few["cone"] - 1.0


def test_verdict_reads_two_standard_errors_of_the_seeds_and_the_reference():
    from blockhash.studies.density.sampling import verdict

    def s(flux, se, blur=0.02, blur_se=0.001):
        return {"flux": flux, "flux_se": se, "flux_region": flux, "flux_region_se": se,
                "blur_region": blur, "blur_region_se": blur_se}

    assert verdict(s(1.005, 0.001)) == ("yes", "yes")
    assert verdict(s(1.025, 0.0005)) == ("no", "yes")
    assert verdict(s(0.985, 0.001)) == ("no", "yes")
    assert verdict(s(1.009, 0.002)) == ("undecided", "yes")
    assert verdict(s(1.0085, 0.0001)) == ("yes", "yes")
    assert verdict(s(1.0085, 0.0001), reference_se=0.001)[0] == "undecided"
    assert verdict(s(1.0, 0.0, blur=0.049, blur_se=0.001))[1] == "undecided"
    assert verdict(s(1.0, 0.0, blur=0.06, blur_se=0.001))[1] == "no"
