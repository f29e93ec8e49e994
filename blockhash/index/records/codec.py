"""The six-word photon record of Figure 4 (paper section 3.2).

Each photon is six 32-bit words (little end = bit 0)::

    word 0, 1, 2   x, y, z as uint32 fixed point (:class:`~blockhash.index.records.fixedpoint.Quantizer`)
    word 3         d | n << 16     incoming direction d, surface normal n (polar codes)
    word 4         c1 | c2 << 16   power channels as IEEE half floats (bits)
    word 5         c3 | c4 << 16

Directions use Jensen's polar representation with the **+y axis as the pole**
(the scenes are y up): ``theta = acos(v_y)`` in [0, pi] and
``phi = atan2(v_z, v_x)`` in [0, 2 pi), each quantised to one byte, the code
being ``theta_byte | phi_byte << 8``.  A code decodes at the centre of its cell,
so the angular error is at most ``THETA_STEP/2 + sin(theta) * PHI_STEP/2``
(<= 3 pi / 512 rad = 1.05 deg); the exact worst case, centre to far corner of an
equator cell, is about sqrt(5) pi / 512 rad = 0.786 deg.  Floor normals (+y) and
photons falling straight down (-y) sit in the pole cells, where the phi term
vanishes: their error is ``THETA_STEP / 2`` = 0.35 deg, the best the code offers.

Powers are stored as ``power / scale`` in half floats, the scale kept beside the
map.  The data-derived scale is the power of two with ``max|power| / scale`` in
[1, 2): dividing and multiplying by it are exact, so the only error is the
float16 rounding: relative <= 2**-11 for channels within 2**14 of the largest
(normal half floats), absolute <= 2**-25 * scale below that (half the subnormal
spacing).  Raw float16 watts would lose 19 % at 1e-7 W.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field

import numpy as np

from blockhash.errors import InputError, InputTypeError
from blockhash.index.records.fixedpoint import Quantizer
from blockhash.index.records.polar_rows import direction_words, kernel_vectors
from blockhash.index.records.power_words import float32_power_bits, pair_words
from blockhash.validate import as_points

#: 32-bit words per photon record (Figure 4): x, y, z, d|n, c1|c2, c3|c4.
WORDS_PER_PHOTON = 6
#: theta in [0, pi] and phi in [0, 2 pi) get one byte each (Jensen's polar code).
THETA_STEP = np.pi / 256
PHI_STEP = 2 * np.pi / 256
#: Allowed deviation of |v| from 1: float32 unit vectors from a tracer are ~1e-7 off;
#: 1e-3 catches unnormalised input while the encoder renormalises what it accepts.
UNIT_LENGTH_TOLERANCE = 1e-3
#: The shader multiplies by the scale in float32: keep it in float32's normal range.
SCALE_MIN, SCALE_MAX = float(np.finfo(np.float32).tiny), float(np.finfo(np.float32).max)
#: Largest finite half float; a scaled power rounding above it would be inf.
FLOAT16_MAX = float(np.finfo(np.float16).max)

# Decoding lookup tables: sin/cos at the centre of each theta and phi cell.
_THETA_C = (np.arange(256) + 0.5) * THETA_STEP
_PHI_C = (np.arange(256) + 0.5) * PHI_STEP
_SIN_T, _COS_T = np.sin(_THETA_C), np.cos(_THETA_C)
_SIN_P, _COS_P = np.sin(_PHI_C), np.cos(_PHI_C)


def _float_dtype(value):
    """float32 for float32 input (kept, not copied to float64), else float64."""
    return np.float32 if getattr(value, "dtype", None) == np.float32 else np.float64


def _unit_vectors(value, name: str) -> np.ndarray:
    v = as_points(value, name, dtype=np.float64)
    length = np.sqrt(np.einsum("ij,ij->i", v, v))
    bad = np.abs(length - 1.0) > UNIT_LENGTH_TOLERANCE
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"{name}[{i}]={v[i].tolist()} has length {length[i]:.6g}; {name} must be unit "
            f"vectors (length within {UNIT_LENGTH_TOLERANCE:g} of 1, {int(bad.sum()):,} row(s) "
            f"are not); normalise them with v / np.linalg.norm(v, axis=1, keepdims=True) "
            "and replace zero vectors")
    return v / length[:, None]


def _int_array(value, name: str, shape_text: str, ndim: int, cols: int | None, bits: int,
               copy: bool = True):
    arr = np.asarray(value)
    if arr.dtype.kind not in "iu":
        raise InputTypeError(f"{name} must be an integer array of shape {shape_text}; got dtype "
                             f"{arr.dtype}. Pass the uint{bits} codes the encoders return")
    if arr.ndim != ndim or (cols is not None and arr.shape[1] != cols):
        raise InputError(f"{name} must have shape {shape_text}; got shape {arr.shape}")
    in_range = arr.dtype.kind == "u" and arr.dtype.itemsize * 8 <= bits  # no value can be out
    if arr.size and not in_range and (arr.min() < 0 or arr.max() >= 2**bits):
        raise InputError(f"{name} holds values in [{arr.min()}, {arr.max()}]; uint{bits} codes "
                         f"must lie in [0, {2**bits - 1}]. Pass the codes the encoders return")
    return arr.astype(np.dtype(f"uint{bits}"), copy=copy)


def _same_rows(arrays: dict) -> None:
    (first, a), *rest = arrays.items()
    for name, b in rest:
        if len(b) != len(a):
            raise InputError(f"{name} has shape {b.shape} but {first} has shape {a.shape}; both "
                             "need one row per photon (the same number of rows)")


def _polar_codes(v: np.ndarray) -> np.ndarray:
    theta = np.arccos(np.clip(v[:, 1], -1.0, 1.0))
    phi = np.arctan2(v[:, 2], v[:, 0])
    phi = np.where(phi < 0, phi + 2 * np.pi, phi)  # -tiny + 2 pi may round to 2 pi: % 256 below
    t = np.minimum(np.floor(theta / THETA_STEP), 255).astype(np.uint16)
    p = (np.floor(phi / PHI_STEP).astype(np.int64) % 256).astype(np.uint16)
    return (t | (p << 8)).astype(np.uint16)


def encode_directions(vectors) -> np.ndarray:
    """Quantise unit vectors to 16-bit polar codes (section 3.2, Jensen's representation).

    ``vectors`` : (n, 3) float, length within ``UNIT_LENGTH_TOLERANCE`` of 1 (renormalised
    here).  Returns (n,) uint16 ``theta_byte | phi_byte << 8``, ``theta = acos(v_y)``,
    ``phi = atan2(v_z, v_x)``.
    """
    return _polar_codes(_unit_vectors(vectors, "vectors"))


def decode_directions(codes) -> np.ndarray:
    """Polar codes -> unit vectors at the centre of each code's cell (section 3.2).

    ``codes`` : (n,) uint16 from :func:`encode_directions`.  Returns (n, 3) float32 unit
    vectors ``(sin t cos p, cos t, sin t sin p)``, from 256-entry tables.
    """
    c = _int_array(codes, "codes", "(n,)", 1, None, 16)
    t, p = c & 0xFF, c >> 8
    s = _SIN_T[t]
    return np.stack([s * _COS_P[p], _COS_T[t], s * _SIN_P[p]], axis=1).astype(np.float32)


#: The codes of a photon map given no directions (falling straight down) and no normals (+y).
DEFAULT_DIRECTION_CODE = np.uint32(_polar_codes(np.array([[0.0, -1.0, 0.0]]))[0])
DEFAULT_NORMAL_CODE = np.uint32(_polar_codes(np.array([[0.0, 1.0, 0.0]]))[0])
#: (65536, 3) float32: the unit vector each 16-bit polar code stands for.
POLAR_UNIT_VECTORS = decode_directions(np.arange(1 << 16, dtype=np.uint16))


def _check_scale(scale, name: str = "scale") -> float:
    if isinstance(scale, bool) or not isinstance(scale, numbers.Real):
        raise InputTypeError(f"{name} must be a real number; got {scale!r} "
                             f"({type(scale).__name__})")
    s = float(scale)
    if not (np.isfinite(s) and SCALE_MIN <= s <= SCALE_MAX):
        raise InputError(f"{name}={s!r} must be positive, finite and in float32's normal range "
                         f"[{SCALE_MIN:.3g}, {SCALE_MAX:.3g}] (the shader multiplies in float32); "
                         "pass scale=None to derive it from the powers")
    return s


def _as_powers(value) -> np.ndarray:
    """(n, 3) or (n, 4) finite watts as float64."""
    p = np.asarray(value)
    if p.dtype.kind not in "fiu":
        raise InputTypeError(f"powers must be a real numeric array of shape (n, 3) or (n, 4); got "
                             f"dtype {p.dtype}. Convert it with np.asarray(..., dtype=np.float64)")
    if p.ndim != 2 or p.shape[1] not in (3, 4):
        raise InputError(f"powers must have shape (n, 3) (RGB) or (n, 4); got shape {p.shape}. "
                         "Pass one row of channel powers in watts per photon")
    p = p.astype(np.float64)
    bad = ~np.isfinite(p).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"powers[{i}]={p[i].tolist()} is not finite ({int(bad.sum()):,} row(s)); "
                         "fix or drop those photons before encoding")
    return p


def encode_powers(powers, *, scale=None) -> tuple[np.ndarray, float]:
    """Store power channels as half floats relative to a scale (section 3.2, Figure 4).

    Parameters
    ----------
    powers : (n, 3) or (n, 4) float
        Watts per channel; signed values are allowed.  RGB input gets c4 = 0.
    scale : float, optional
        Watts per stored unit.  Default: the power of two with ``max|powers| / scale``
        in [1, 2) (1.0 when every power is 0), which keeps scaling exact.

    Returns
    -------
    bits : (n, 4) uint16
        IEEE half-float bits of ``powers / scale``.
    scale : float
        The scale used; :func:`decode_powers` needs it.
    """
    p = _as_powers(powers)
    if p.shape[1] == 3:
        p = np.concatenate([p, np.zeros((len(p), 1))], axis=1)
    peak = float(np.abs(p).max()) if p.size else 0.0
    scale = _check_scale(_derived_scale(peak) if scale is None else scale)
    with np.errstate(over="ignore"):
        half = (p / scale).astype(np.float16)
    if np.isinf(half).any():
        raise InputError(f"scale={scale!r} makes powers up to {peak:.6g} W overflow float16 "
                         f"(max {FLOAT16_MAX:g}); use scale >= {peak / FLOAT16_MAX:.6g} "
                         "or scale=None")
    return half.view(np.uint16), scale


def _derived_scale(peak: float) -> float:
    """The power of two with ``peak / scale`` in [1, 2) (1.0 for a peak of 0)."""
    scale = 1.0 if peak == 0.0 else float(2.0 ** np.floor(np.log2(peak)))
    if not SCALE_MIN <= scale <= SCALE_MAX:
        raise InputError(f"powers peak at {peak:.6g} W, outside float32's normal range "
                         f"[{SCALE_MIN:.3g}, {SCALE_MAX:.3g}] that the shader decodes in; "
                         "express the powers in other units")
    return scale


def decode_powers(bits, scale, *, dtype=np.float32) -> np.ndarray:
    """Half-float bits and scale -> watts (section 3.2).

    Parameters
    ----------
    bits : (n, 4) uint16
        From :func:`encode_powers`.
    scale : float
        The scale returned with them.
    dtype : {np.float32, np.float64}
        float32 mirrors the shader; with a power-of-two scale >= 2**-102 (every
        data-derived one for physical powers) both give the same values.

    Returns
    -------
    (n, 4) dtype
        ``float(bits) * scale``.
    """
    b = _int_array(bits, "bits", "(n, 4)", 2, 4, 16)
    dt = np.dtype(dtype) if dtype in (np.float32, np.float64, "float32", "float64") else None
    if dt is None:
        raise InputTypeError(f"dtype must be np.float32 or np.float64; got {dtype!r}")
    return b.view(np.float16).astype(dt) * dt.type(_check_scale(scale))


def pack_records(position_codes, direction_codes, normal_codes, power_bits) -> np.ndarray:
    """Assemble (n, 6) uint32 photon records laid out as in Figure 4 (module docstring).

    Takes position_codes (n, 3) uint32, direction_codes and normal_codes (n,) uint16 and
    power_bits (n, 4) uint16; any integer dtype holding values in range is accepted.
    """
    pos = _int_array(position_codes, "position_codes", "(n, 3)", 2, 3, 32, copy=False)
    d = _int_array(direction_codes, "direction_codes", "(n,)", 1, None, 16).astype(np.uint32)
    n = _int_array(normal_codes, "normal_codes", "(n,)", 1, None, 16).astype(np.uint32)
    c = _int_array(power_bits, "power_bits", "(n, 4)", 2, 4, 16, copy=False)
    _same_rows({"position_codes": pos, "direction_codes": d, "normal_codes": n, "power_bits": c})
    rec = np.empty((len(pos), WORDS_PER_PHOTON), dtype=np.uint32)
    rec[:, :3] = pos
    rec[:, 3] = d | (n << 16)
    rec[:, 4:6] = pair_words(c)
    return rec


def unpack_records(records):
    """Split (n, 6) uint32 records into the fields :func:`pack_records` took, bit for bit.

    Returns position_codes (n, 3) uint32, direction_codes (n,) uint16, normal_codes (n,)
    uint16 and power_bits (n, 4) uint16.
    """
    rec = _int_array(records, "records", f"(n, {WORDS_PER_PHOTON})", 2, WORDS_PER_PHOTON, 32)
    lo, hi = (rec[:, 3:] & 0xFFFF).astype(np.uint16), (rec[:, 3:] >> 16).astype(np.uint16)
    power = np.stack([lo[:, 1], hi[:, 1], lo[:, 2], hi[:, 2]], axis=1)
    return rec[:, :3].copy(), lo[:, 0].copy(), hi[:, 0].copy(), power


@dataclass(frozen=True, eq=False)
class PhotonRecords:
    """An encoded photon map (section 3.2): records plus what decodes them.

    Attributes
    ----------
    records : (n, 6) uint32, read-only
        Figure 4 records (see the module docstring for the layout).
    quantizer : Quantizer
        Decodes words 0-2 to positions.
    power_scale : float
        Watts per stored power unit.
    """

    records: np.ndarray = field(repr=False)
    quantizer: Quantizer
    power_scale: float

    def __post_init__(self):
        rec = _int_array(self.records, "records", f"(n, {WORDS_PER_PHOTON})", 2,
                         WORDS_PER_PHOTON, 32)
        rec.setflags(write=False)  # _int_array returned a private copy
        if not isinstance(self.quantizer, Quantizer):
            raise InputTypeError(f"quantizer must be a Quantizer; got "
                                 f"{type(self.quantizer).__name__}. Use Quantizer.for_points")
        object.__setattr__(self, "records", rec)
        object.__setattr__(self, "power_scale", _check_scale(self.power_scale, "power_scale"))

    @classmethod
    def encode(cls, positions, *, directions=None, normals=None, powers=None) -> "PhotonRecords":
        """Encode photons.

        Parameters
        ----------
        positions : (n, 3) float, n >= 1
        directions : (n, 3) float unit vectors, optional
            Incoming (travel) directions; default (0, -1, 0), falling straight down.
        normals : (n, 3) float unit vectors, optional
            Surface normals; default (0, 1, 0).
        powers : (n, 3) or (n, 4) float, optional
            Watts per channel; default 1 W in each of R, G, B and 0 in c4.
        """
        if getattr(positions, "__len__", None) and len(positions):
            try:
                return cls._encode_compiled(positions, directions, normals, powers)
            except InputError:
                pass  # the whole arrays' checks below name the offending row
        p = as_points(positions, "positions", dtype=np.float64)
        if len(p) == 0:
            raise InputError("positions has shape (0, 3); a photon map needs at least one photon")
        n = len(p)
        given = {"positions": p}

        def vector_codes(value, name, default):
            if value is None:  # a missing payload is one constant code
                return np.full(n, default, dtype=np.uint16)
            given[name] = _unit_vectors(value, name)
            return None

        d_codes = vector_codes(directions, "directions", DEFAULT_DIRECTION_CODE)
        n_codes = vector_codes(normals, "normals", DEFAULT_NORMAL_CODE)
        if powers is not None:
            given["powers"] = _as_powers(powers)
        _same_rows(given)
        if d_codes is None:
            d_codes = _polar_codes(given["directions"])
        if n_codes is None:
            n_codes = _polar_codes(given["normals"])
        if powers is None:
            one, scale = encode_powers(np.ones((1, 3)))
            bits = np.broadcast_to(one, (n, 4))
        else:
            bits, scale = encode_powers(given["powers"])
        quantizer = Quantizer.for_points(p)
        rec = pack_records(quantizer.encode(p), d_codes, n_codes, bits)
        return cls._own(rec, quantizer, scale)

    @classmethod
    def _encode_compiled(cls, positions, directions, normals, powers) -> "PhotonRecords":
        """:meth:`encode`'s records by compiled passes over the whole map (the direction words
        by :func:`.polar_rows.direction_words`, float32 powers' half floats by
        :func:`.power_words.float32_power_bits`).  Raises InputError on any bad input, which
        :meth:`encode`'s whole-array checks then name."""
        p = as_points(positions, "positions", dtype=_float_dtype(positions))
        n = len(p)
        for name, value in (("directions", directions), ("normals", normals), ("powers", powers)):
            if value is not None and len(value) != n:
                raise InputError(f"{name}: one row per photon")
        quantizer = Quantizer.for_points(p)
        scale = 1.0
        if powers is not None:
            raw = np.asarray(powers)
            if raw.dtype.kind not in "fiu" or raw.ndim != 2 or raw.shape[1] not in (3, 4):
                raise InputError("powers: (n, 3) or (n, 4) reals")
            scale = _derived_scale(float(np.abs(raw).max()))
        rec = np.empty((n, WORDS_PER_PHOTON), dtype=np.uint32)
        bad = direction_words(kernel_vectors(directions, n, "directions"),
                              kernel_vectors(normals, n, "normals"),
                              DEFAULT_DIRECTION_CODE, DEFAULT_NORMAL_CODE, UNIT_LENGTH_TOLERANCE,
                              THETA_STEP, PHI_STEP, rec[:, 3])
        if max(bad) >= 0:
            raise InputError("directions and normals: unit vectors")
        if powers is None:
            bits = encode_powers(np.ones((1, 3)))[0]
        elif raw.dtype == np.float32:
            bits = float32_power_bits(raw, scale)
        else:
            bits = encode_powers(raw, scale=scale)[0]
        rec[:, 4:6] = pair_words(bits)
        rec[:, :3] = quantizer.encode(p)
        return cls._own(rec, quantizer, scale)

    @classmethod
    def _own(cls, records: np.ndarray, quantizer: Quantizer, power_scale: float) -> "PhotonRecords":
        """Wrap records built here ((n, 6) uint32, referenced nowhere else) without the
        checks and the private copy that the constructor makes of records given to it."""
        obj = cls.__new__(cls)
        records.setflags(write=False)
        object.__setattr__(obj, "records", records)
        object.__setattr__(obj, "quantizer", quantizer)
        object.__setattr__(obj, "power_scale", _check_scale(power_scale, "power_scale"))
        return obj

    def positions(self) -> np.ndarray:
        """(n, 3) float32 positions, decoded as the shader does.

        The codes are exact to one step (2**-32 of the box), but float32 rounding adds
        up to about 2**-23 * (box size + |coordinate|): compare codes where it matters.
        """
        return self.quantizer.decode(self.records[:, :3])

    def directions(self) -> np.ndarray:
        """(n, 3) float32 incoming directions (cell centres)."""
        return decode_directions((self.records[:, 3] & 0xFFFF).astype(np.uint16))

    def normals(self) -> np.ndarray:
        """(n, 3) float32 surface normals (cell centres)."""
        return decode_directions((self.records[:, 3] >> 16).astype(np.uint16))

    def powers(self) -> np.ndarray:
        """(n, 4) float32 watts per channel."""
        return decode_powers(unpack_records(self.records)[3], self.power_scale)

    def __len__(self) -> int:
        return len(self.records)

    def __repr__(self) -> str:
        lo = np.round(self.quantizer.lo.astype(np.float64), 6).tolist()
        hi = np.round(self.quantizer.hi, 6).tolist()
        return (f"PhotonRecords(n={len(self):,}, box={lo}..{hi}, "
                f"power_scale={self.power_scale!r}, bytes={self.records.nbytes:,})")

