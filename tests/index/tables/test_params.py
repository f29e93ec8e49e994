import math

import pytest
from conftest import photon_set

from blockhash.index.tables.params import (
    ADAPTIVE_REFERENCE_A,
    DEFAULT_PHOTONS_PER_BUCKET,
    DEFAULT_REFS_PER_PHOTON,
    adaptive_params,
    paper_params,
    resolve_params,
)
from blockhash.index.tables.thresholds import ThresholdLayout


@pytest.mark.parametrize("n,k,A", [(200_000, 50, 8), (2_000_000, 50, 16), (1000, 10, 1)])
def test_paper_preset_is_section_5(n, k, A):
    p = paper_params(n, k=k, A=A)
    lnN = round(math.log(n))
    assert (p.L, p.P, p.B) == (lnN, (lnN,) * 3, math.ceil(A * k / (10 * lnN)))
    assert p.layout == ThresholdLayout.MARGINAL


def test_paper_example_of_section_5():
    # "assuming A = 16, N = 2000000, k = 50, then ceil(B) = 6"
    assert paper_params(2_000_000, k=50, A=16).B == 6


@pytest.mark.parametrize("A", [1, 2, 8, 64])
def test_default_buckets_follow_A_and_memory_stays_bounded(A):
    pts = photon_set("caustic", 20_000)
    p = adaptive_params(pts, k=50, A=A)
    assert p.layout == ThresholdLayout.ADAPTIVE and p.probe
    assert p.bucket_photons == max(10, DEFAULT_PHOTONS_PER_BUCKET * 50 * A / ADAPTIVE_REFERENCE_A)
    # B references per bucket of S photons: L B / S references per photon, at every A.
    assert p.L * p.B / p.bucket_photons <= DEFAULT_REFS_PER_PHOTON


def test_paper_preset_does_not_probe():
    pts = photon_set("uniform", 5_000)
    assert not resolve_params(pts, k=8, A=4, preset="paper").probe


def test_overrides_replace_only_what_is_given():
    pts = photon_set("uniform", 10_000)
    p = resolve_params(pts, k=8, A=4, preset="paper", B=7)
    assert p.B == 7 and p.L == round(math.log(10_000)) and p.preset == "paper+overrides"
    assert resolve_params(pts, k=8, A=4, P=3).P == (3, 3, 3)
    assert resolve_params(pts, k=8, A=4, P=(4, 1, 2)).P == (4, 1, 2)
    assert "layout=marginal" in repr(resolve_params(pts, k=8, A=4, layout="marginal"))
