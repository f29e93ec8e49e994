"""Exact kNN and the accuracy metrics of paper section 6, against brute force and hand counts."""

from __future__ import annotations

import numpy as np
import pytest

from blockhash import BlockHashError
from blockhash.evaluate.datasets import DISTRIBUTIONS
from blockhash.evaluate.metrics import Accuracy, accuracy, dilations, exact_knn, false_negatives, summarize

#: cKDTree and numpy compute the same Euclidean distance with differently ordered sums:
#: a few ulps apart, far below 1e-12 relative.
DISTANCE_RTOL = 1e-12


def _brute_knn(points: np.ndarray, queries: np.ndarray, k: int):
    """Oracle: all pairwise distances, stable argsort, first k."""
    d = np.linalg.norm(queries[:, None, :] - points[None, :, :], axis=2)
    idx = np.argsort(d, axis=1, kind="stable")[:, :k]
    return np.take_along_axis(d, idx, axis=1), idx


def _brute_false_negatives(approx: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """Oracle: size of the set difference exact - approx, row by row."""
    return np.array([len(set(e.tolist()) - set(a.tolist())) for a, e in zip(approx, exact)])


@pytest.mark.parametrize("k", [1, 5, 16])
@pytest.mark.parametrize("scenario", ["uniform", "clustered", "caustic"])
def test_exact_knn_equals_brute_force(scenario, k):
    rng = np.random.default_rng(k)
    points = DISTRIBUTIONS[scenario](300, rng)
    queries = points[rng.integers(0, 300, 40)] + rng.normal(scale=0.05, size=(40, 3))
    d, i = exact_knn(points, queries, k)
    bd, bi = _brute_knn(points, queries, k)
    assert d.shape == i.shape == (40, k)
    np.testing.assert_array_equal(i, bi)
    np.testing.assert_allclose(d, bd, rtol=DISTANCE_RTOL, atol=0)


def test_exact_knn_pads_with_inf_and_index_n_when_k_exceeds_n():
    points = np.random.default_rng(0).random((3, 3))
    queries = np.random.default_rng(1).random((2, 3))
    d, i = exact_knn(points, queries, 5)
    bd, bi = _brute_knn(points, queries, 3)
    np.testing.assert_allclose(d[:, :3], bd, rtol=DISTANCE_RTOL, atol=0)
    np.testing.assert_array_equal(i[:, :3], bi)
    assert np.isinf(d[:, 3:]).all()
    np.testing.assert_array_equal(i[:, 3:], 3)


def test_exact_knn_rejects_k_below_one():
    with pytest.raises(BlockHashError, match="k"):
        exact_knn(np.zeros((4, 3)), np.zeros((2, 3)), 0)


@pytest.mark.parametrize("replace_share, missing_share", [(0.0, 0.0), (0.3, 0.0), (0.3, 0.2),
                                                          (1.0, 0.0), (0.0, 1.0), (0.6, 0.3)])
def test_false_negatives_match_a_brute_force_set_difference(replace_share, missing_share):
    # Approximate rows: the exact row shuffled, some entries swapped for other photons,
    # some for the missing index n (cKDTree's "fewer than k found").
    rng = np.random.default_rng(int(100 * replace_share + 10 * missing_share))
    n, m, k = 200, 300, 12
    exact = np.stack([rng.choice(n, k, replace=False) for _ in range(m)])
    approx = rng.permuted(exact, axis=1)
    replace = rng.random((m, k)) < replace_share
    approx[replace] = rng.integers(0, n, replace.sum())
    missing = rng.random((m, k)) < missing_share
    approx[missing] = n
    fn = false_negatives(approx, exact, n)
    assert fn.shape == (m,) and fn.dtype == np.int64
    expected = _brute_false_negatives(approx, exact)
    np.testing.assert_array_equal(fn, expected)
    if replace_share or missing_share:  # the scenario must hold some misses to count
        assert expected.sum() > 0


@pytest.mark.parametrize("approx, exact, n, expected", [
    pytest.param([[4, 1, 7]], [[1, 4, 7]], 10, [0], id="identical-set-other-order"),
    pytest.param([[0, 1, 2]], [[3, 4, 5]], 10, [3], id="disjoint"),
    pytest.param([[10, 10, 10]], [[3, 4, 5]], 10, [3], id="nothing-found"),
    pytest.param([[3, 4, 10]], [[3, 4, 5]], 10, [1], id="one-missing-index-n"),
    pytest.param([[3, 3, 3]], [[3, 4, 5]], 10, [2], id="duplicate-approx-entries"),
    pytest.param([[0, 9], [9, 0]], [[0, 9], [1, 2]], 10, [0, 2], id="two-rows"),
])
def test_false_negatives_hand_counted_cases(approx, exact, n, expected):
    np.testing.assert_array_equal(false_negatives(np.array(approx), np.array(exact), n), expected)


def test_false_negatives_do_not_count_padding_of_the_exact_set():
    assert false_negatives(np.array([[0, 1, 3]]), np.array([[0, 1, 3]]), 3).tolist() == [0]


def test_dilations_are_one_for_identical_results():
    d = np.sort(np.random.default_rng(0).random((50, 8)), axis=1) + 0.01
    max_d, avg_d = dilations(d, d.copy())
    np.testing.assert_array_equal(max_d, 1.0)
    np.testing.assert_array_equal(avg_d, 1.0)


@pytest.mark.parametrize("approx, exact, max_expected, avg_expected", [
    pytest.param([1.0, 2.0, 4.0], [1.0, 2.0, 3.0], 4 / 3, 7 / 6, id="last-further"),
    pytest.param([2.0, 2.0], [1.0, 1.0], 2.0, 2.0, id="all-doubled"),
    pytest.param([1.0, 2.0, np.inf], [1.0, 2.0, 3.0], np.inf, np.inf, id="fewer-than-k-found"),
    pytest.param([0.0, 0.0], [0.0, 0.0], 1.0, 1.0, id="all-coincident"),
    pytest.param([0.0, 0.5], [0.0, 0.0], np.inf, np.inf, id="exact-coincident-approx-not"),
])
def test_dilations_hand_computed_cases(approx, exact, max_expected, avg_expected):
    max_d, avg_d = dilations(np.array([approx]), np.array([exact]))
    np.testing.assert_allclose(max_d, [max_expected], rtol=1e-15)
    np.testing.assert_allclose(avg_d, [avg_expected], rtol=1e-15)


@pytest.mark.parametrize("values, expected", [
    pytest.param([1.0, 2.0, 3.0, 4.0, np.inf],
                 {"mean": 2.5, "p50": 2.5, "p90": 3.7, "p99": 3.97, "max": 4.0, "infinite": 1},
                 id="one-infinite"),
    pytest.param([5.0, 1.0, 3.0],
                 {"mean": 3.0, "p50": 3.0, "p90": 4.6, "p99": 4.96, "max": 5.0, "infinite": 0},
                 id="all-finite-unsorted"),
    pytest.param([7.0], {"mean": 7.0, "p50": 7.0, "p90": 7.0, "p99": 7.0, "max": 7.0, "infinite": 0},
                 id="single"),
])
def test_summarize_reports_mean_percentiles_max_and_infinite_count(values, expected):
    # Percentiles interpolate linearly between order statistics (numpy's default):
    # for 1..4, p90 sits at rank 0.9 * 3 = 2.7 -> 3.7.
    out = summarize(values)
    assert out.keys() == expected.keys()
    assert out == pytest.approx(expected, rel=1e-12)
    assert isinstance(out["infinite"], int)


def test_summarize_of_only_infinite_values_is_nan_with_their_count():
    out = summarize([np.inf, np.inf, np.inf])
    assert out["infinite"] == 3
    assert all(np.isnan(out[key]) for key in ("mean", "p50", "p90", "p99", "max"))


def test_accuracy_combines_the_metrics_for_a_hand_computed_case():
    n, inf = 6, np.inf
    exact = (np.array([[1.0, 2.0], [1.0, 1.0], [0.5, 1.0]]), np.array([[0, 1], [2, 3], [5, 0]]))
    approx = (np.array([[1.0, 3.0], [2.5, inf], [0.5, 1.0]]), np.array([[0, 4], [4, n], [5, 0]]))
    # Per query: false negatives 1, 2, 0; max dilation 3/2, inf, 1; avg dilation 4/3, inf, 1.
    acc = accuracy(approx, exact, n)
    assert isinstance(acc, Accuracy)
    assert (acc.k, acc.queries) == (2, 3)
    assert acc.false_negatives == pytest.approx(
        {"mean": 1.0, "p50": 1.0, "p90": 1.8, "p99": 1.98, "max": 2.0, "infinite": 0}, rel=1e-12)
    assert acc.max_dilation == pytest.approx(
        {"mean": 1.25, "p50": 1.25, "p90": 1.45, "p99": 1.495, "max": 1.5, "infinite": 1}, rel=1e-12)
    assert acc.avg_dilation == pytest.approx(
        {"mean": 7 / 6, "p50": 7 / 6, "p90": 1.3, "p99": 1.33, "max": 4 / 3, "infinite": 1}, rel=1e-12)
    assert acc.fn_fraction == pytest.approx(0.5)
    assert "false_negatives=50.0% of k" in repr(acc) and "queries=3" in repr(acc)


def test_accuracy_of_the_exact_search_against_itself_is_perfect():
    rng = np.random.default_rng(3)
    points = DISTRIBUTIONS["caustic"](500, rng)
    exact = exact_knn(points, points[:50] + 0.01, 8)
    acc = accuracy(exact, exact, len(points))
    assert acc.false_negatives["max"] == 0
    assert acc.max_dilation["max"] == acc.max_dilation["mean"] == 1.0
    assert acc.avg_dilation["infinite"] == 0


def test_far_queries_are_those_farther_from_the_photons_than_their_neighbourhood_is_wide():
    from blockhash.evaluate.metrics import far_queries

    rng = np.random.default_rng(0)
    disc = np.column_stack([rng.uniform(-1, 1, 4000), np.zeros(4000), rng.uniform(-1, 1, 4000)])
    q = np.array([[0.0, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 5.0, 0.0], [10.0, 0.0, 0.0]])
    d, _ = exact_knn(disc, q, 20)
    # On the disc and just above it: the neighbourhood is wider than the distance; 5 m above
    # it or 9 m beyond its edge: all 20 neighbours lie at about the same distance.
    np.testing.assert_array_equal(far_queries(d), [False, False, True, True])
