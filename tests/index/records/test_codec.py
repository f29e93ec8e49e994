"""Tests for blockhash.index.records.codec: the six-word photon record of Figure 4 (section 3.2)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from blockhash import InputError, InputTypeError
from blockhash.index.records.codec import (
    WORDS_PER_PHOTON,
    PhotonRecords,
    decode_directions,
    decode_powers,
    encode_directions,
    encode_powers,
    pack_records,
    unpack_records,
)
from blockhash.index.records.fixedpoint import Quantizer


def _polar(t, p):
    """Unit vector at colatitude t from +y and azimuth p = atan2(z, x)."""
    return np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], axis=1)


# --- Error bounds, each with the reason for its value -------------------------------------

#: Polar cells: theta in [0, pi] and phi in [0, 2 pi) each split into 256 (one byte).
THETA_STEP = np.pi / 256
PHI_STEP = 2 * np.pi / 256
#: Decoding at the cell centre leaves at most half a step in theta (along the meridian)
#: plus half a step in phi along the parallel, whose length scales with sin(theta):
#: by the triangle inequality error <= THETA_STEP/2 + sin(theta) * PHI_STEP/2, at most
#: 3 pi / 512 rad (1.05 deg).
DIRECTION_MAX_ERROR = THETA_STEP / 2 + PHI_STEP / 2


def _corner_distances():
    """Exact worst error per theta row: the angle from a cell's centre to its far corner.

    The dot product with the centre falls monotonically along each parallel away from the
    centre's meridian, and along a meridian it is a sinusoid whose minimum lies far outside
    the cell, so the farthest point of a cell is a corner.
    """
    tc = (np.arange(256) + 0.5) * THETA_STEP
    centre = _polar(tc, np.zeros(256))
    return np.max([np.arccos(np.clip(np.einsum("ij,ij->i", centre, _polar(
        tc + s * THETA_STEP / 2, np.full(256, PHI_STEP / 2))), -1, 1)) for s in (-1, 1)], axis=0)


#: The sharp bound per theta row, largest at the equator: about sqrt(5) pi / 512 rad
#: (0.786 deg), the half-diagonal of a THETA_STEP x PHI_STEP cell.
CORNER_ERROR = _corner_distances()
#: Decoded vectors are float32 (components off by <= 2**-24 relative, ~1e-7 rad) and the
#: test measures angles in float64: 1e-6 rad covers both and is 0.005 % of a step.
ANGLE_SLACK = 1e-6
#: float16 keeps 11 significant bits; rounding to nearest is off by at most half a unit in
#: the last place, 2**-11 relative, for normal half floats.  The data-derived scale is a
#: power of two, so dividing and multiplying by it add no error.
POWER_REL_ERROR = 2.0**-11
#: Channels within 2**14 of the largest stay normal: the largest stored value is in [1, 2)
#: and the smallest normal half float is 2**-14.
POWER_NORMAL_RANGE = 2.0**14
#: Below that, half floats are subnormal with spacing 2**-24: rounding is off by at most
#: 2**-25 stored units, i.e. 2**-25 * scale watts (and scale <= the largest |power|).
POWER_ABS_ERROR_UNITS = 2.0**-25
#: Decoding to float32 (lo + float32(u) * step) rounds u to 24 bits (2**-24 of the extent),
#: the product (another 2**-24 of the extent) and the sum (2**-24 of |coordinate|).
POSITION_F32_ROUNDING = 2.0**-23


def _random_unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _angle(a, b):
    """Angle between rows of a and b in float64, accurate near 0 (atan2 of |cross|, dot)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


# --- Positions (words 0-2) -----------------------------------------------------------------

def _scenario(name, rng):
    p = rng.uniform(-1.5, 1.5, size=(20_000, 3))
    if name == "uniform":
        return p
    if name == "box_faces_and_corners":
        lo, hi = p.min(axis=0), p.max(axis=0)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        faces = p[:6].copy()
        for axis in range(3):
            faces[2 * axis, axis], faces[2 * axis + 1, axis] = lo[axis], hi[axis]
        return np.concatenate([p, corners, faces])
    if name == "flat_floor_y0":
        p[:, 1] = 0.0
        return p
    if name == "flat_rim_y03":
        p[:, 1] = 0.3
        return p
    if name == "far_from_origin":
        return p * 0.01 + [1000.0, -250.0, 40.0]
    raise ValueError(name)


SCENARIOS = ["uniform", "box_faces_and_corners", "flat_floor_y0", "flat_rim_y03",
             "far_from_origin"]


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_position_codes_lie_within_one_fixed_point_step_per_axis(scenario):
    p = _scenario(scenario, np.random.default_rng(1))
    rec = PhotonRecords.encode(p)
    q = rec.quantizer
    # Exact rational arithmetic: float64 cannot resolve a 2**-32 step far from the origin.
    lo = [Fraction(float(x)) for x in q.lo]
    step = [Fraction(float(x)) for x in q.step]
    rows = np.r_[0:len(p):10, len(p) - 14:len(p)]  # every tenth point and the face points
    offsets = [(Fraction(float(p[i, a])) - lo[a] - int(rec.records[i, a]) * step[a]) / step[a]
               for i in rows for a in range(3)]
    assert min(offsets) >= 0 and max(offsets) < 1, (float(min(offsets)), float(max(offsets)))
    assert max(offsets) > 0.99  # the points fill their cells: the check can see a step


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_decoded_positions_lie_within_one_step_plus_float32_rounding(scenario):
    p = _scenario(scenario, np.random.default_rng(2))
    rec = PhotonRecords.encode(p)
    q = rec.quantizer
    decoded = rec.positions()
    assert decoded.dtype == np.float32 and decoded.shape == p.shape
    extent = q.hi - q.lo.astype(np.float64)
    magnitude = np.maximum(np.abs(q.lo.astype(np.float64)), np.abs(q.hi))
    bound = q.step.astype(np.float64) + POSITION_F32_ROUNDING * (extent + magnitude)
    err = np.abs(decoded.astype(np.float64) - p).max(axis=0)
    assert (err <= bound).all(), (err, bound)


def test_flat_axis_decodes_every_photon_to_the_same_height():
    p = _scenario("flat_rim_y03", np.random.default_rng(3))
    rec = PhotonRecords.encode(p)
    assert np.unique(rec.records[:, 1]).size == 1
    assert np.unique(rec.positions()[:, 1]).size == 1


# --- Directions and normals (word 3) --------------------------------------------------------

def _direction_cases(rng):
    k = np.arange(257)
    return np.concatenate([
        _random_unit(rng, 200_000),
        [[0, 1, 0], [0, -1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]],
        _polar(rng.uniform(0, 3 * THETA_STEP, 5000), rng.uniform(0, 2 * np.pi, 5000)),
        _polar(np.pi - rng.uniform(0, 3 * THETA_STEP, 5000), rng.uniform(0, 2 * np.pi, 5000)),
        _polar(np.minimum(k, 256) * THETA_STEP, np.full(257, 0.3)),     # theta cell edges
        _polar(np.full(257, 1.0), k * PHI_STEP),                         # phi cell edges
        _polar(np.full(4, 1.0), np.array([-1e-17, 1e-17, -1e-12, 2 * np.pi - 1e-15])),  # wrap
    ])


def test_directions_decode_within_half_a_cell_in_theta_and_phi():
    v = _direction_cases(np.random.default_rng(4))
    decoded = decode_directions(encode_directions(v))
    err = _angle(v, decoded)
    theta = np.arccos(np.clip(v[:, 1], -1, 1))
    per_vector = THETA_STEP / 2 + np.sin(theta) * PHI_STEP / 2 + ANGLE_SLACK
    worst = int(np.argmax(err - per_vector))
    assert err[worst] <= per_vector[worst], (v[worst], err[worst], per_vector[worst])
    assert err.max() <= DIRECTION_MAX_ERROR + ANGLE_SLACK
    row = np.minimum(np.floor(theta / THETA_STEP), 255).astype(int)
    assert (err <= CORNER_ERROR[row] + ANGLE_SLACK).all()
    # The sharp bound is reached, so the decoder really uses cell centres.
    assert err.max() > CORNER_ERROR.max() - 1e-4


@pytest.mark.parametrize("pole", [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
def test_poles_y_up_normal_and_downward_photon_are_off_by_half_a_theta_step(pole):
    err = _angle([pole], decode_directions(encode_directions([pole])))[0]
    assert abs(err - THETA_STEP / 2) <= ANGLE_SLACK


def test_decoded_directions_are_unit_float32_vectors():
    codes = np.arange(2**16, dtype=np.uint16)
    v = decode_directions(codes)
    assert v.dtype == np.float32 and v.shape == (2**16, 3)
    assert np.abs(np.linalg.norm(v.astype(np.float64), axis=1) - 1).max() < 1e-6


def test_every_direction_code_reencodes_to_itself():
    codes = np.arange(2**16, dtype=np.uint16)
    np.testing.assert_array_equal(encode_directions(decode_directions(codes)), codes)


def test_slightly_unnormalised_vectors_encode_like_normalised_ones():
    v = _random_unit(np.random.default_rng(5), 10_000)
    np.testing.assert_array_equal(encode_directions(v * 1.0009), encode_directions(v))


# --- Powers (words 4 and 5) -----------------------------------------------------------------

def _check_power_bounds(p, bits, scale):
    p4 = np.concatenate([p, np.zeros((len(p), 1))], axis=1) if p.shape[1] == 3 else p
    decoded = decode_powers(bits, scale)
    assert decoded.dtype == np.float32 and decoded.shape == p4.shape
    err = np.abs(decoded.astype(np.float64) - p4)
    peak = np.abs(p4).max()
    assert scale <= peak
    normal = np.abs(p4) >= peak / POWER_NORMAL_RANGE
    rel = err[normal] / np.abs(p4[normal])
    assert rel.max() <= POWER_REL_ERROR, rel.max() / POWER_REL_ERROR
    assert (err[~normal] <= POWER_ABS_ERROR_UNITS * scale).all()
    return rel.max()


@pytest.mark.parametrize("watts, photons", [(1.0, 10**7), (1e6, 10**3)], ids=["1W_1e7", "1MW_1e3"])
def test_light_power_over_photon_count_roundtrips_within_half_float_precision(watts, photons):
    rng = np.random.default_rng(6)
    reflectance = np.array([0.95, 0.78, 0.45])
    p = watts / photons * reflectance * rng.uniform(0.5, 1.0, size=(50_000, 1))
    bits, scale = encode_powers(p)
    assert bits.dtype == np.uint16 and bits.shape == (50_000, 4)
    worst = _check_power_bounds(p, bits, scale)
    assert worst > 0.5 * POWER_REL_ERROR  # the bound is tight, not vacuous


def test_mixed_magnitudes_and_signs_meet_relative_or_absolute_bound():
    rng = np.random.default_rng(7)
    p = 10.0 ** rng.uniform(-12, 3, size=(50_000, 4)) * rng.choice([-1.0, 1.0], size=(50_000, 4))
    p[:10] = 0.0
    bits, scale = encode_powers(p)
    _check_power_bounds(p, bits, scale)
    assert np.array_equal(np.signbit(decode_powers(bits, scale)), np.signbit(p))


def test_power_of_two_scale_decodes_identically_in_float32_and_float64():
    p = np.random.default_rng(8).uniform(-3e-7, 3e-7, size=(10_000, 4))
    bits, scale = encode_powers(p)
    assert scale == 2.0 ** np.floor(np.log2(np.abs(p).max()))
    np.testing.assert_array_equal(decode_powers(bits, scale).astype(np.float64),
                                  decode_powers(bits, scale, dtype=np.float64))


def test_rgb_powers_store_zero_in_the_fourth_channel():
    bits, _ = encode_powers([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    assert (bits[:, 3] == 0).all() and (bits[:, :3] != 0).all()


def test_all_zero_powers_get_unit_scale():
    bits, scale = encode_powers(np.zeros((3, 4)))
    assert scale == 1.0 and (bits == 0).all()


def test_caller_scale_is_used_as_given():
    bits, scale = encode_powers([[3.0, 0, 0, 0]], scale=1.5)
    assert scale == 1.5 and bits[0, 0] == np.float16(2.0).view(np.uint16)


# --- Record layout and packing ----------------------------------------------------------------

def test_packing_and_unpacking_are_lossless_bit_for_bit():
    rng = np.random.default_rng(9)
    n = 5000
    pos = rng.integers(0, 2**32, size=(n, 3), dtype=np.uint64).astype(np.uint32)
    pos[0] = [0, 2**32 - 1, 2**31]
    d, nrm = (rng.integers(0, 2**16, size=n).astype(np.uint16) for _ in range(2))
    d[0], nrm[0] = 0xFFFF, 0
    c = rng.integers(0, 2**16, size=(n, 4)).astype(np.uint16)  # includes NaN and inf bits
    c[0] = [0xFFFF, 0x7C00, 0x8000, 0x0001]
    rec = pack_records(pos, d, nrm, c)
    assert rec.dtype == np.uint32 and rec.shape == (n, WORDS_PER_PHOTON)
    out = unpack_records(rec)
    for got, want in zip(out, (pos, d, nrm, c)):
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(pack_records(*out), rec)


def test_record_words_follow_figure_4_layout():
    rec = pack_records([[1, 2, 0xFFFFFFFF]], [0x1234], [0xABCD], [[0x3C00, 0xC000, 0x0001, 0x7BFF]])
    assert rec[0].tolist() == [1, 2, 0xFFFFFFFF, 0xABCD1234, 0xC0003C00, 0x7BFF0001]


def test_encoded_photon_record_words_are_the_documented_fields():
    d = _polar(np.array([(200 + 0.5) * THETA_STEP]), np.array([(37 + 0.5) * PHI_STEP]))
    n = _polar(np.array([(3 + 0.5) * THETA_STEP]), np.array([(250 + 0.5) * PHI_STEP]))
    rec = PhotonRecords.encode([[0.25, 0.0, -0.5]], directions=d, normals=n,
                               powers=[[2.0, -0.5, 0.25, 1.5]])
    words = rec.records[0].tolist()
    assert words[:3] == rec.quantizer.encode([[0.25, 0.0, -0.5]])[0].tolist()
    assert words[3] == (200 | 37 << 8) | (3 | 250 << 8) << 16
    # scale 2: stored 1.0, -0.25, 0.125, 0.75 as half-float bits
    assert rec.power_scale == 2.0
    assert words[4] == 0x3C00 | 0xB400 << 16
    assert words[5] == 0x3000 | 0x3A00 << 16


def test_photon_records_default_to_downward_white_photons_on_a_floor():
    rec = PhotonRecords.encode(np.random.default_rng(10).uniform(-1, 1, size=(4, 3)))
    assert len(rec) == 4 and rec.records.shape == (4, WORDS_PER_PHOTON)
    assert _angle(rec.directions(), [[0, -1, 0]] * 4).max() <= THETA_STEP / 2 + ANGLE_SLACK
    assert _angle(rec.normals(), [[0, 1, 0]] * 4).max() <= THETA_STEP / 2 + ANGLE_SLACK
    np.testing.assert_array_equal(rec.powers(), [[1, 1, 1, 0]] * 4)


def test_photon_records_are_read_only_and_print_a_summary():
    rec = PhotonRecords.encode([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]], powers=[[4.0, 0, 0]] * 2)
    with pytest.raises(ValueError, match="read-only"):
        rec.records[0, 0] = 7
    text = repr(rec)
    assert text.startswith("PhotonRecords(n=2,") and "power_scale=4.0" in text
    assert isinstance(rec.quantizer, Quantizer)


# --- Errors -----------------------------------------------------------------------------------

P2 = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]
CASES = {
    "empty_photon_set": (lambda: PhotonRecords.encode(np.zeros((0, 3))),
                         InputError, r"positions has shape \(0, 3\).*at least one photon"),
    "nan_position": (lambda: PhotonRecords.encode([[0, np.nan, 0]]),
                     InputError, r"positions\[0\].*not finite"),
    "zero_normal": (lambda: PhotonRecords.encode(P2, normals=[[0, 1, 0], [0, 0, 0]]),
                    InputError, r"normals\[1\]=\[0\.0, 0\.0, 0\.0\] has length 0;.*normalise"),
    "long_direction": (lambda: PhotonRecords.encode(P2, directions=[[0, 2, 0], [0, 1, 0]]),
                       InputError, r"directions\[0\]=.* has length 2;.*within 0\.001 of 1"),
    "nan_direction": (lambda: encode_directions([[np.nan, 1, 0]]),
                      InputError, r"vectors\[0\].*not finite"),
    "direction_shape": (lambda: encode_directions([1.0, 0, 0]),
                        InputError, r"vectors must have shape \(n, 3\); got shape \(3,\)"),
    "direction_dtype": (lambda: encode_directions([["a", "b", "c"]]),
                        InputTypeError, r"vectors must be a real numeric array"),
    "row_mismatch": (lambda: PhotonRecords.encode(P2, normals=[[0, 1, 0]]),
                     InputError, r"normals has shape \(1, 3\) but positions has shape \(2, 3\)"),
    "power_rows": (lambda: PhotonRecords.encode(P2, powers=[[1, 1, 1]] * 3),
                   InputError, r"powers has shape \(3, 3\) but positions has shape \(2, 3\)"),
    "power_shape": (lambda: encode_powers(np.ones((2, 5))),
                    InputError, r"powers must have shape \(n, 3\) \(RGB\) or \(n, 4\); got \(?.*5"),
    "power_nan": (lambda: encode_powers([[1, 1, 1], [1, np.inf, 1]]),
                  InputError, r"powers\[1\]=.*not finite"),
    "power_dtype": (lambda: encode_powers(np.array([["1", "2", "3"]])),
                    InputTypeError, r"powers must be a real numeric array"),
    "scale_overflow": (lambda: encode_powers([[1e6, 0, 0]], scale=1.0),
                       InputError, r"scale=1\.0 makes powers up to 1e\+06 W overflow float16.*"
                                   r"use scale >= 15\.26"),
    "scale_zero": (lambda: encode_powers([[1, 0, 0]], scale=0.0),
                   InputError, r"scale=0\.0 must be positive, finite.*scale=None"),
    "scale_negative": (lambda: encode_powers([[1, 0, 0]], scale=-2),
                       InputError, r"scale=-2\.0 must be positive"),
    "scale_nan": (lambda: decode_powers(np.zeros((1, 4), np.uint16), float("nan")),
                  InputError, r"scale=nan must be positive, finite"),
    "scale_inf": (lambda: encode_powers([[1, 0, 0]], scale=np.inf),
                  InputError, r"scale=inf must be positive, finite"),
    "scale_beyond_float32": (lambda: encode_powers([[1, 0, 0]], scale=1e39),
                             InputError, r"scale=1e\+39 .*float32's normal range"),
    "scale_type": (lambda: encode_powers([[1, 0, 0]], scale="2"),
                   InputTypeError, r"scale must be a real number; got '2' \(str\)"),
    "scale_bool": (lambda: encode_powers([[1, 0, 0]], scale=True),
                   InputTypeError, r"scale must be a real number; got True"),
    "powers_beyond_float32": (lambda: encode_powers([[1e300, 0, 0]]), InputError,
                              r"powers peak at 1e\+300 W, outside float32's normal range"),
    "decode_dtype": (lambda: decode_powers(np.zeros((1, 4), np.uint16), 1.0, dtype=np.float16),
                     InputTypeError, r"dtype must be np\.float32 or np\.float64"),
    "float_codes": (lambda: decode_directions([0.5]),
                    InputTypeError, r"codes must be an integer array of shape \(n,\); got dtype"),
    "code_range": (lambda: decode_directions([70_000]),
                   InputError, r"codes holds values in \[70000, 70000\]; uint16 codes must lie "
                               r"in \[0, 65535\]"),
    "pack_rows": (lambda: pack_records(np.zeros((2, 3), np.uint32), [0, 0], [0],
                                       np.zeros((2, 4), int)), InputError,
                  r"normal_codes has shape \(1,\) but position_codes has shape \(2, 3\)"),
    "pack_negative": (lambda: pack_records([[-1, 0, 0]], [0], [0], [[0, 0, 0, 0]]),
                      InputError, r"position_codes holds values in \[-1, 0\]; uint32 codes"),
    "records_dtype": (lambda: PhotonRecords(np.zeros((1, 6)), Quantizer.for_points(P2), 1.0),
                      InputTypeError, r"records must be an integer array of shape \(n, 6\)"),
    "quantizer_type": (lambda: PhotonRecords(np.zeros((1, 6), np.uint32), None, 1.0),
                       InputTypeError, r"quantizer must be a Quantizer; got NoneType"),
    "record_scale": (lambda: PhotonRecords(np.zeros((1, 6), np.uint32), Quantizer.for_points(P2),
                                           0), InputError, r"power_scale=0\.0 must be positive"),
    "unpack_shape": (lambda: unpack_records(np.zeros((2, 5), np.uint32)),
                     InputError, r"records must have shape \(n, 6\); got shape \(2, 5\)"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_raises_an_error_naming_parameter_value_and_way_out(case):
    call, exc, match = CASES[case]
    with pytest.raises(exc, match=match):
        call()


def test_the_compiled_encode_gives_the_public_encoders_records():
    """A map is encoded by compiled passes (polar_rows, power_words): the records and scale of
    the public encoders, float32 or float64 input; a bad row is named by its index in the whole
    map (the whole-array checks name it)."""
    import blockhash.index.records.codec as codec

    rng = np.random.default_rng(5)
    n = 5000
    pos = rng.random((n, 3)) * 7 - 2
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    w = rng.random((n, 3)) * 3e-3
    for p in (pos, pos.astype(np.float32)):
        for powers in (w, w.astype(np.float32), (w * 1e6).astype(np.int64)):
            got = codec.PhotonRecords.encode(p, directions=d, normals=d[::-1], powers=powers)
            bits, scale = codec.encode_powers(powers)
            want = codec.pack_records(got.quantizer.encode(p), codec.encode_directions(d),
                                      codec.encode_directions(d[::-1]), bits)
            np.testing.assert_array_equal(got.records, want)
            assert got.power_scale == scale
    bad = d.copy()
    bad[3000] = 0.0
    with pytest.raises(InputError, match=r"directions\[3000\]"):
        codec.PhotonRecords.encode(pos, directions=bad)
    nan = w.copy()
    nan[4100, 1] = np.nan
    with pytest.raises(InputError, match=r"powers\[4100\]"):
        codec.PhotonRecords.encode(pos, powers=nan)
