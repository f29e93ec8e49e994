"""Synthetic photon sets: shapes, determinism, and the geometry each generator promises."""

from __future__ import annotations

import numpy as np
import pytest

from blockhash import InputError, InputTypeError
from blockhash.evaluate.datasets import CAUSTIC_SHARES, DISTRIBUTIONS, caustic_like, planar, uniform

NAMES = sorted(DISTRIBUTIONS)
#: Points placed on the ring wall as (R cos t, R sin t) have radius R to a few ulps.
RADIUS_ATOL = 1e-12


def test_distributions_registry_lists_the_four_generators():
    assert NAMES == ["caustic", "clustered", "planar", "uniform"]


@pytest.mark.parametrize("n", [1, 7, 1000])
@pytest.mark.parametrize("name", NAMES)
def test_generators_return_n_finite_float64_points(name, n):
    p = DISTRIBUTIONS[name](n, np.random.default_rng(n))
    assert p.shape == (n, 3) and p.dtype == np.float64
    assert np.isfinite(p).all()


@pytest.mark.parametrize("name", NAMES)
def test_generators_are_deterministic_for_a_seed(name):
    generate = DISTRIBUTIONS[name]
    a = generate(2000, np.random.default_rng(42))
    np.testing.assert_array_equal(a, generate(2000, np.random.default_rng(42)))
    assert not np.array_equal(a, generate(2000, np.random.default_rng(43)))


@pytest.mark.parametrize("name", NAMES)
def test_generators_return_an_empty_set_for_n_zero(name):
    p = DISTRIBUTIONS[name](0, np.random.default_rng(0))
    assert p.shape == (0, 3) and p.dtype == np.float64


@pytest.mark.parametrize("n", [-1, -1000])
@pytest.mark.parametrize("name", NAMES)
def test_negative_n_is_rejected(name, n):
    with pytest.raises(InputError, match=rf"n={n:,} is out of range; allowed 0 <= n <= inf"):
        DISTRIBUTIONS[name](n, np.random.default_rng(0))


@pytest.mark.parametrize("name", NAMES)
def test_non_integer_n_is_rejected(name):
    with pytest.raises(InputTypeError, match=r"n must be an integer; got 2\.5"):
        DISTRIBUTIONS[name](2.5, np.random.default_rng(0))


def test_uniform_points_lie_in_the_unit_cube():
    p = uniform(5000, np.random.default_rng(0))
    assert (p >= 0).all() and (p < 1).all()


def test_planar_points_lie_on_the_square_at_y_zero():
    p = planar(5000, np.random.default_rng(0))
    assert (p[:, 1] == 0).all()
    assert (p[:, [0, 2]] >= -1).all() and (p[:, [0, 2]] < 1).all()


def test_caustic_shares_sum_to_one_with_three_percent_on_the_wall():
    assert sum(CAUSTIC_SHARES) == pytest.approx(1.0, abs=1e-12)
    assert CAUSTIC_SHARES[-1] == pytest.approx(0.03)


@pytest.mark.parametrize("ring_radius", [0.5, 0.8])
def test_caustic_photons_are_on_the_floor_or_on_the_ring_wall(ring_radius):
    n = 20_000
    p = caustic_like(n, np.random.default_rng(11), ring_radius=ring_radius)
    floor = p[:, 1] == 0
    # The floor count is binomial(n, 0.97): standard deviation sqrt(n * 0.97 * 0.03) = 24
    # photons; allow 5 sigma (a chance of ~6e-7 to fail for a correct generator).
    floor_share = 1.0 - CAUSTIC_SHARES[-1]
    assert abs(floor.sum() - floor_share * n) <= 5 * np.sqrt(n * floor_share * (1 - floor_share))
    wall = p[~floor]
    np.testing.assert_allclose(np.hypot(wall[:, 0], wall[:, 2]), ring_radius, rtol=0, atol=RADIUS_ATOL)
    assert (wall[:, 1] >= 0).all() and (wall[:, 1] <= 0.3).all()


def test_caustic_photons_are_shuffled_not_grouped_by_component():
    # The generator permutes the parts; the wall photons must not all sit at the end.
    p = caustic_like(10_000, np.random.default_rng(12))
    wall_rows = np.flatnonzero(p[:, 1] != 0)
    assert wall_rows.min() < 1000 and wall_rows.max() > 9000


def test_caustic_floor_photons_lie_inside_the_ring():
    # The caustic (nested cardioid arcs) falls on the floor inside the ring.
    # Hot spots (centres within |x|, |z| <= 0.3, widths <= 3 cm) may leak a handful: allow 0.5%.
    p = caustic_like(20_000, np.random.default_rng(13))
    floor = p[p[:, 1] == 0]
    assert np.mean(np.hypot(floor[:, 0], floor[:, 2]) > 0.5) < 0.005


@pytest.mark.parametrize("name", ["clustered", "caustic"])
def test_two_seeds_sample_one_distribution(name):
    # Fixed geometry (LAYOUT_SEED): points drawn with another seed land where the photons are,
    # so their 10th-neighbour distances among the photons match the photons' own.
    from scipy.spatial import cKDTree

    a = DISTRIBUTIONS[name](20_000, np.random.default_rng(1))
    b = DISTRIBUTIONS[name](2_000, np.random.default_rng(2))
    tree = cKDTree(a)
    own = tree.query(a[:2_000], k=11)[0][:, -1]  # the first neighbour is the point itself
    other = tree.query(b, k=10)[0][:, -1]
    for q in (50, 90, 99):
        assert np.percentile(other, q) == pytest.approx(np.percentile(own, q), rel=0.25)
