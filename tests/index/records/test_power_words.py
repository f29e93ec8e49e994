"""The compiled power words (blockhash/index/records/power_words.py) round every value to the
half float numpy gives (ties to even, subnormals, overflow), and the words are the public
encoder's."""

import numpy as np
import pytest

from blockhash.index.records.codec import encode_powers
from blockhash.index.records.power_words import half_bits, power_words


def awkward_values(rng):
    """Values at every half float exponent and across the float64 range: halves' exact
    values, the ties between neighbours, one ulp either side, subnormals, the edge of
    underflow and of overflow, zeros of both signs, infinities and NaN."""
    halves = np.arange(1 << 16, dtype=np.uint16).view(np.float16).astype(np.float64)
    halves = halves[np.isfinite(halves)]
    with np.errstate(over="ignore"):  # the largest half's next is infinity
        nxt = np.nextafter(halves.astype(np.float16), np.float16(np.inf)).astype(np.float64)
    ties = (halves + nxt)[np.isfinite(nxt)] / 2
    near = np.concatenate([np.nextafter(ties, np.inf), np.nextafter(ties, -np.inf)])
    edges = np.array([2.0**-25, 2.0**-24, 2.0**-14, 65504.0, 65519.99, 65520.0, 65536.0, 1e300,
                      1e-300, 5e-324, 0.0, -0.0, np.inf, -np.inf, np.nan])
    wide = rng.standard_normal(200_000) * 10.0 ** rng.uniform(-12, 6, 200_000)
    return np.concatenate([halves, ties, near, edges, -edges, wide])


def test_half_bits_round_as_numpy_does():
    values = awkward_values(np.random.default_rng(1))
    got = np.array([half_bits(b) for b in values.view(np.uint64)], dtype=np.uint32)
    with np.errstate(over="ignore", invalid="ignore"):
        want = values.astype(np.float16).view(np.uint16).astype(np.uint32)
    nan = np.isnan(values)
    np.testing.assert_array_equal(got[~nan], want[~nan])
    assert np.all((got[nan] & 0x7C00) == 0x7C00) and np.all(got[nan] & 0x3FF)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("channels", [3, 4])
def test_power_words_are_the_public_encoders(dtype, channels):
    rng = np.random.default_rng(channels)
    powers = (rng.exponential(size=(50_000, channels)) * 10.0 ** rng.uniform(-9, 0, (50_000, 1)))
    powers[::7] *= -1  # signed powers are allowed
    powers = powers.astype(dtype)
    bits, scale = encode_powers(powers)
    out4, out5 = np.empty(len(powers), np.uint32), np.empty(len(powers), np.uint32)
    assert power_words(powers, scale, out4, out5) == -1
    b = bits.astype(np.uint32)
    np.testing.assert_array_equal(out4, b[:, 0] | (b[:, 1] << 16))
    np.testing.assert_array_equal(out5, b[:, 2] | (b[:, 3] << 16))


def test_the_first_row_not_finite_or_overflowing_is_reported():
    powers = np.ones((40_000, 3))
    powers[30_000, 2] = np.inf
    powers[20_000, 0] = np.nan
    out = np.empty(len(powers), np.uint32)
    assert power_words(powers, 1.0, out, out.copy()) == 20_000
    powers[20_000, 0] = 7e4  # past half's largest at scale 1
    assert power_words(powers, 1.0, out, out.copy()) == 20_000
