import math

import pytest

from blockhash.index.params import (DEFAULT_REFS_PER_PHOTON, buckets_per_axis, default_params,
                              paper_params, resolve_params)
from blockhash.index.thresholds import ThresholdLayout
from conftest import photon_set


@pytest.mark.parametrize("n,k,A", [(200_000, 50, 8), (2_000_000, 50, 16), (1000, 10, 1)])
def test_paper_preset_is_section_5(n, k, A):
    p = paper_params(n, k=k, A=A)
    lnN = round(math.log(n))
    assert (p.L, p.P, p.B) == (lnN, (lnN,) * 3, math.ceil(A * k / (10 * lnN)))
    assert p.layout == ThresholdLayout.MARGINAL


def test_paper_example_of_section_5():
    # "assuming A = 16, N = 2000000, k = 50, then ceil(B) = 6"
    assert paper_params(2_000_000, k=50, A=16).B == 6


def test_flat_axis_gets_one_bucket_and_the_others_share_the_rest():
    assert buckets_per_axis([1.0, 0.0, 1.0], 400) == (20, 1, 20)
    assert buckets_per_axis([2.0, 0.001, 1.0], 200) == (20, 1, 10)
    assert buckets_per_axis([1.0, 1.0, 1.0], 1000) == (10, 10, 10)


@pytest.mark.parametrize("name,flat_y", [("caustic", True), ("planar", True), ("uniform", False)])
def test_default_preset_adapts_to_the_distribution(name, flat_y):
    pts = photon_set(name, 100_000)
    p = default_params(pts, k=50, A=8)
    assert (p.P[1] == 1) == flat_y
    assert p.layout == ThresholdLayout.NESTED
    # About 2k photons per bucket, and the memory bound holds.
    assert 50 <= len(pts) / p.buckets <= 200
    assert p.refs / len(pts) <= DEFAULT_REFS_PER_PHOTON


def test_default_tables_do_not_depend_on_A():
    pts = photon_set("caustic", 50_000)
    a, b = default_params(pts, k=50, A=1), default_params(pts, k=50, A=16)
    assert (a.L, a.P, a.B) == (b.L, b.P, b.B)


def test_overrides_replace_only_what_is_given():
    pts = photon_set("uniform", 10_000)
    p = resolve_params(pts, k=8, A=4, preset="paper", B=7)
    assert p.B == 7 and p.L == round(math.log(10_000)) and p.preset == "paper+overrides"
    assert resolve_params(pts, k=8, A=4, P=3).P == (3, 3, 3)
    assert resolve_params(pts, k=8, A=4, P=(4, 1, 2)).P == (4, 1, 2)
    assert "layout=marginal" in repr(resolve_params(pts, k=8, A=4, layout="marginal"))
