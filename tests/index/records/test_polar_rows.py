"""The compiled direction words (blockhash/index/records/polar_rows.py) and the encoder's fast
path built on them give the numpy statement's records bit for bit, and bad vectors still get
the whole-array checks' messages."""

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.index.records.codec import (
    PHI_STEP,
    THETA_STEP,
    UNIT_LENGTH_TOLERANCE,
    PhotonRecords,
    encode_directions,
    encode_powers,
    pack_records,
)
from blockhash.index.records.polar_rows import direction_words


def awkward_vectors(rng, n):
    """Unit vectors with the cases a polar code rounds at: the poles, phi at 0 and just below
    2 pi (a tiny negative z), axis directions, and lengths at the tolerance's edges."""
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    special = np.array([[0, 1, 0], [0, -1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1],
                        [1, 0, -1e-300], [1, 0, -1e-17], [0.6, 0.8, 0], [-0.6, -0.8, -0.0]])
    v[:len(special)] = special[:n]
    scale = 1.0 + rng.uniform(-0.9, 0.9, n) * UNIT_LENGTH_TOLERANCE
    return v * scale[:, None]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_direction_words_equal_the_numpy_codes(dtype):
    rng = np.random.default_rng(11)
    d = awkward_vectors(rng, 100_000).astype(dtype)
    nrm = awkward_vectors(rng, 100_000).astype(dtype)
    out = np.empty(len(d), dtype=np.uint32)
    assert direction_words(d, nrm, 0, 0, UNIT_LENGTH_TOLERANCE, THETA_STEP, PHI_STEP, out) == (-1, -1)
    want = encode_directions(d).astype(np.uint32) | (encode_directions(nrm).astype(np.uint32) << 16)
    np.testing.assert_array_equal(out, want)


def test_the_first_vector_off_unit_length_is_reported():
    rng = np.random.default_rng(2)
    d = awkward_vectors(rng, 50_000)
    nrm = awkward_vectors(rng, 50_000)
    d[[40_000, 30_000]] *= 1.01
    nrm[20_000] = np.nan
    out = np.empty(len(d), dtype=np.uint32)
    assert direction_words(d, nrm, 0, 0, UNIT_LENGTH_TOLERANCE, THETA_STEP, PHI_STEP,
                           out) == (30_000, 20_000)


@pytest.mark.parametrize("n", [1, 5_000, 300_000])
def test_the_encoder_gives_the_records_of_the_public_encoders(n):
    rng = np.random.default_rng(n)
    p = rng.normal(size=(n, 3)).astype(np.float32)
    d, nrm = awkward_vectors(rng, n).astype(np.float32), awkward_vectors(rng, n)
    power = rng.exponential(size=(n, 3)).astype(np.float32)
    rec = PhotonRecords.encode(p, directions=d, normals=nrm, powers=power)
    bits, scale = encode_powers(power)
    want = pack_records(rec.quantizer.encode(p), encode_directions(d), encode_directions(nrm), bits)
    np.testing.assert_array_equal(rec.records, want)
    assert rec.power_scale == scale
    plain = PhotonRecords.encode(p)  # the default direction (falling) and normal (+y)
    np.testing.assert_array_equal(plain.records[:, 3],
                                  encode_directions([[0.0, -1.0, 0.0]]).astype(np.uint32)[0]
                                  | encode_directions([[0.0, 1.0, 0.0]]).astype(np.uint32)[0] << 16)


def test_a_bad_normal_is_named_by_the_whole_array_check():
    rng = np.random.default_rng(4)
    p = rng.normal(size=(1000, 3))
    nrm = awkward_vectors(rng, 1000)
    nrm[123] = 0.0
    with pytest.raises(InputError, match=r"normals\[123\]=\[0\.0, 0\.0, 0\.0\] has length 0"):
        PhotonRecords.encode(p, normals=nrm)
