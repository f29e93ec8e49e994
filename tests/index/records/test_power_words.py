"""The float32 power words (blockhash/index/records/power_words.py) are the public encoder's
float64 statement's, bit for bit, at every scale a map's powers take, and a power that is not
finite or overflows is reported by its row."""

import numpy as np
import pytest

from blockhash.index.records.codec import encode_powers
from blockhash.index.records.power_words import power_words


@pytest.mark.parametrize("channels", [3, 4])
@pytest.mark.parametrize("magnitude", [1e-30, 1e-9, 1.0, 1e9])
def test_power_words_are_the_public_encoders(channels, magnitude):
    rng = np.random.default_rng(channels)
    powers = rng.exponential(size=(50_000, channels)) * 10.0 ** rng.uniform(-12, 0, (50_000, 1))
    powers[::7] *= -1  # signed powers are allowed
    powers[::11, 0] = 0.0
    powers = (powers * magnitude).astype(np.float32)
    bits, scale = encode_powers(powers)  # float64 arithmetic
    out4, out5 = np.empty(len(powers), np.uint32), np.empty(len(powers), np.uint32)
    assert power_words(powers, scale, out4, out5) == -1
    b = bits.astype(np.uint32)
    np.testing.assert_array_equal(out4, b[:, 0] | (b[:, 1] << 16))
    np.testing.assert_array_equal(out5, b[:, 2] | (b[:, 3] << 16))


def test_the_first_row_not_finite_or_overflowing_is_reported():
    powers = np.ones((40_000, 3), dtype=np.float32)
    powers[30_000, 2] = np.inf
    powers[20_000, 0] = np.nan
    out = np.empty(len(powers), np.uint32)
    assert power_words(powers, 1.0, out, out.copy()) == 20_000
    powers[20_000, 0] = 7e4  # past half's largest at scale 1
    assert power_words(powers, 1.0, out, out.copy()) == 20_000
