"""The density estimate's options: the shader equals the CPU reference for each, and each
does what it is for on photon sets whose answer is known."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import DOWN, FLOOR, KD, LAMBERT, floor_points, surfaces  # noqa: F401

from blockhash.cli import main
from blockhash.errors import InputError
from blockhash.evaluate.testing import assert_images_close
from blockhash.frame.caustic import CausticPass, estimate_cpu, estimate_from_neighbours
from blockhash.frame.estimate import FILTERS, EstimateOptions, kernel

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

#: Radiance of a unit square lit by 1 W, Lambertian kd: L = kd E / pi.
PLANE_L = KD / np.pi


@pytest.fixture(scope="module")
def corner():
    """A floor and a wall (z = 0.5, facing +z) meeting, 20,000 photons each."""
    return surfaces([(20_000, 1, 0.0, FLOOR), (20_000, 2, 0.5, (0.0, 0.0, 1.0))], k=20)


#: Every estimate form, filter and test at least once (each define value compiles once).
OPTIONS = [EstimateOptions(estimate="paper", normal_cos=None),
           EstimateOptions(estimate="unbiased", normal_cos=None),
           EstimateOptions(estimate="unbiased", filter="cone", normal_cos=0.5),
           EstimateOptions(filter="cone", normal_cos=0.5),
           EstimateOptions(estimate="conserving", filter="epanechnikov", normal_cos=None, disc=0.2),
           EstimateOptions(estimate="paper", filter="epanechnikov", normal_cos=0.9, disc=0.3),
           EstimateOptions(filter="silverman", normal_cos=None, disc=0.1),
           EstimateOptions(estimate="paper", filter="cone", normal_cos=-1.0, disc=0.05)]


@pytest.mark.slow
@pytest.mark.parametrize("options", OPTIONS, ids=lambda o: o.label)
def test_shader_estimate_equals_the_cpu_estimate_for_every_option(corner, options, tmp_path):
    # The CPU estimate takes its neighbours from the GL lookup itself, so that this pins down
    # the estimate alone (the lookup's own agreement is tests/gl/test_gl_lookup.py's).
    pts = floor_points(16, 16, z=(0.45, 0.75), view=(0.6, 0.8, 0.0))
    mats = [((KD, 0.4, 0.3), (0.25, 0.25, 0.25), 20.0)]
    cp = CausticPass(corner, backend="egl")
    gl = cp.render(pts, mats, options=options)
    cpu = estimate_from_neighbours(corner, pts, mats, lambda q: cp.lookup.query(q), 20,
                                   options=options)
    assert np.any(cpu > 0)
    assert_images_close(gl, cpu, max_rel_rms=1e-4, out_dir=tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("variant", ["paper", "binary-branch-on-network"])
def test_shader_estimate_equals_the_cpu_estimate_with_other_lookup_variants(corner, variant, tmp_path):
    # The estimate reads the found photons from bh_best, which every selection fills alike.
    pts = floor_points(16, 16, z=(0.45, 0.75), view=(0.6, 0.8, 0.0))
    cp = CausticPass(corner, backend="egl")
    gl = cp.render(pts, LAMBERT, variant=variant)
    cpu = estimate_from_neighbours(corner, pts, LAMBERT,
                                   lambda q: cp.lookup.query(q, variant=variant), 20)
    assert np.any(cpu > 0)
    assert_images_close(gl, cpu, max_rel_rms=1e-4, out_dir=tmp_path)


@pytest.fixture(scope="module")
def plane():
    return surfaces([(100_000, 1, 0.0, FLOOR)], k=50)


def test_unbiased_estimate_has_no_k_over_k_minus_1_bias_and_the_paper_form_has(plane):
    # Uniform photons: the m-th photon lies on the circle, so summing all k overestimates
    # by k / (k - 1) = 2 % at k = 50; the noise of the mean over the grid is about 0.5 %.
    unbiased = estimate_cpu(plane, floor_points(), LAMBERT,
                            options=EstimateOptions(estimate="unbiased", filter="none")).mean()
    paper = estimate_cpu(plane, floor_points(), LAMBERT,
                         options=EstimateOptions(estimate="paper", filter="none")).mean()
    assert unbiased == pytest.approx(PLANE_L, rel=0.01)
    assert paper == pytest.approx(PLANE_L * 50 / 49, rel=0.01)
    assert paper / unbiased == pytest.approx(50 / 49, rel=0.002)


@pytest.mark.slow
@pytest.mark.parametrize("name", FILTERS)
def test_each_filter_is_normalised_over_the_disc(plane, name):
    t = np.sqrt(np.linspace(0, 1, 200_001))  # t^2 uniform = points uniform over the disc
    assert kernel(name, t ** 2).mean() == pytest.approx(1.0, abs=1e-4)
    L = estimate_cpu(plane, floor_points(), LAMBERT, options=EstimateOptions(filter=name)).mean()
    assert L == pytest.approx(PLANE_L, rel=0.015)


@pytest.mark.slow
def test_photons_of_a_wall_do_not_brighten_the_floor_beside_it():
    # Floor points less than a search radius (r ~ 1.3 cm) in front of the wall; without
    # the normal test the wall's photons fall in their spheres and count.  The mean is
    # over about 50 independent estimates of 14 % noise each: 2 %.
    wall = surfaces([(100_000, 1, 0.0, FLOOR), (100_000, 2, 0.5, (0.0, 0.0, 1.0))], k=50)
    pts = floor_points(8, 64, z=(0.501, 0.51))
    with_test = estimate_cpu(wall, pts, LAMBERT, options=EstimateOptions(normal_cos=0.5)).mean()
    without = estimate_cpu(wall, pts, LAMBERT, options=EstimateOptions(normal_cos=None)).mean()
    assert with_test == pytest.approx(PLANE_L, rel=0.05)
    assert without > 1.2 * PLANE_L


def test_flattened_neighbourhood_leaves_out_a_parallel_surface_just_above():
    # A second floor 1 cm above the first, its photons' normals parallel: the normal test
    # cannot tell them apart, the disc of height 0.25 r (r about 1.3 cm here) can.
    two = surfaces([(20_000, 1, 0.0, FLOOR), (20_000, 1, 0.01, FLOOR)], k=20)
    pts = floor_points()
    # (box filter: the cone would already weigh the far layer's photons down)
    box = EstimateOptions(estimate="unbiased", filter="none")
    disc = estimate_cpu(two, pts, LAMBERT, options=replace(box, disc=0.25)).mean()
    sphere = estimate_cpu(two, pts, LAMBERT, options=box).mean()
    assert disc == pytest.approx(PLANE_L, rel=0.05)
    assert sphere > 1.3 * PLANE_L


@pytest.mark.parametrize("kwargs, match", [
    ({"filter": "gauss"}, "filter='gauss' is not known; choose one of none, cone"),
    ({"estimate": "jensen"}, "estimate='jensen' is not known; choose one of paper, unbiased, conserving"),
    ({"normal_cos": 1.5}, r"normal_cos=1.5 must lie in \[-1, 1\]"),
    ({"disc": -0.1}, "disc=-0.1 must be >= 0"),
    ({"normal_cos": "0.5"}, "normal_cos must be a number or None"),
])
def test_bad_options_are_named(kwargs, match):
    with pytest.raises(InputError, match=match):
        EstimateOptions(**kwargs)


def test_render_command_takes_the_estimate_flags(tmp_path, capsys):
    from pathlib import Path

    ring = Path(__file__).resolve().parents[2] / "scenes" / "ring.toml"
    out = tmp_path / "ring.exr"
    assert main(["render", str(ring), "-o", str(out), "--photons", "5000", "--size", "24x24",
                 "--method", "cpu", "--estimate", "paper", "--filter", "cone",
                 "--normal-test", "off", "--disc", "0.5"]) == 0
    assert "density estimate: paper/cone/noff/disc0.5" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["render", str(ring), "--normal-test", "2"])
    assert "--normal-test '2': expected a number in [-1, 1] or 'off'" in capsys.readouterr().err


def test_estimate_study_measures_every_option_on_the_same_neighbours(tmp_path):
    from pathlib import Path

    from blockhash.scene.loader import load_scene
    from blockhash.studies.density.estimates import (
        default_options,
        markdown_table,
        study_scene,
        summary_table,
    )

    corner = load_scene(Path(__file__).resolve().parents[2] / "scenes" / "corner.toml")
    study = study_scene(corner, photons=(3_000,), ks=(20,), size=(24, 24), supersample=1,
                        reference_photons=200_000, cache_dir=tmp_path, progress=lambda s: None)
    rows = study["rows"]
    labels = [r["option"] for r in rows if r["search"] == "bh"]
    assert labels == [o.label for o in default_options()]
    assert EstimateOptions().label in labels
    assert {r["option"] for r in rows if r["search"] == "exact"} == {labels[0], EstimateOptions().label}
    assert all(np.isfinite([r["flux"], r["blur"], r["flux_region"], r["blur_region"]]).all() for r in rows)
    # the paper's form sums one photon more per estimate than the unbiased form, nothing else
    by = {r["option"]: r for r in rows if r["search"] == "bh"}
    assert by["paper/none/noff"]["flux"] > by["unbiased/none/noff"]["flux"]
    assert "**default**" in summary_table([study]) and "| corner | 3,000 | 20 | bh |" in markdown_table([study])
