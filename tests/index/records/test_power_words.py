"""The float32 powers' half floats (blockhash/index/records/power_words.py) are the public
encoder's float64 statement's, bit for bit, at every scale a map's powers take; a power that
is not finite or overflows is named by its row; the records' power words pack c1 | c2 << 16
and c3 | c4 << 16."""

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.index.records.codec import encode_powers
from blockhash.index.records.power_words import float32_power_bits, pair_words


@pytest.mark.parametrize("channels", [3, 4])
@pytest.mark.parametrize("magnitude", [1e-30, 1e-9, 1.0, 1e9])
def test_float32_bits_are_the_public_encoders(channels, magnitude):
    rng = np.random.default_rng(channels)
    powers = rng.exponential(size=(50_000, channels)) * 10.0 ** rng.uniform(-12, 0, (50_000, 1))
    powers[::7] *= -1  # signed powers are allowed
    powers[::11, 0] = 0.0
    powers = (powers * magnitude).astype(np.float32)
    bits, scale = encode_powers(powers)  # float64 arithmetic
    np.testing.assert_array_equal(float32_power_bits(powers, scale), bits)


def test_the_first_row_not_finite_or_overflowing_is_named():
    powers = np.ones((40_000, 3), dtype=np.float32)
    powers[30_000, 2] = np.inf
    powers[20_000, 0] = np.nan
    with pytest.raises(InputError, match=r"powers\[20000\]"):
        float32_power_bits(powers, 1.0)
    powers[20_000, 0] = 7e4  # past half's largest at scale 1
    with pytest.raises(InputError, match=r"powers\[20000\]"):
        float32_power_bits(powers, 1.0)


def test_pair_words_put_the_odd_channels_low():
    bits = np.array([[1, 2, 3, 4], [0xFFFF, 0, 0, 0xFFFF]], dtype=np.uint16)
    np.testing.assert_array_equal(pair_words(bits), [[1 | 2 << 16, 3 | 4 << 16],
                                                      [0xFFFF, 0xFFFF << 16]])
