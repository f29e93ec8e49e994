"""Knaus and Zwicker's radius schedule and the splat footprint: the shrink per pass and
the refusals of alpha and footprint."""

import math

import pytest

from blockhash.errors import InputError
from blockhash.passes.schedule import Schedule, shrink


@pytest.mark.parametrize("alpha", [0.0, 1.0, -0.5, 2.0])
def test_alpha_outside_0_1_is_refused(alpha):
    with pytest.raises(InputError, match=r"alpha=.* is outside \(0, 1\)"):
        Schedule(alpha=alpha)


def test_the_radii_shrink_by_knaus_and_zwicker():
    assert shrink(0, 0.7) == 1.0
    for i in range(1, 40):  # r_{i+1}^2 / r_i^2 = (i + alpha) / (i + 1), 1-based passes
        assert shrink(i, 0.7) / shrink(i - 1, 0.7) == pytest.approx((i + 0.7) / (i + 1))
    # the photons within a radius, n r^2 with n ~ passes: grow as n^alpha
    assert shrink(9999, 2 / 3) * 10000 == pytest.approx(10000 ** (2 / 3), rel=0.3)


@pytest.mark.parametrize("footprint", [-1.0, math.inf, math.nan, "1"])
def test_a_footprint_that_is_not_a_finite_number_above_0_is_refused(footprint):
    with pytest.raises(InputError, match="splatted into their pixel must be a finite number"):
        Schedule(footprint=footprint)

