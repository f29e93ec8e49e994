"""Spectra of wavelength:value pairs (``<spectrum value="400:0.3, 500:0.5, ..."/>``) taken to
linear sRGB as Mitsuba 3's RGB variants take them when they load a scene.

The pairs are a piecewise-linear spectrum over their own range (zero outside it), integrated
against the CIE 1931 colour matching functions over 360 .. 830 nm by Mitsuba's rule (1,000
evenly spaced wavelengths, the sum times the range over 1,000), in Mitsuba's normalisation
(the Y function over its integral), and taken from XYZ to linear sRGB:

- a **reflectance** (or any value not on an emitter) is weighted by the D65 illuminant in
  Mitsuba's scale (``MI_CIE_D65_NORMALIZATION``, in the table), so a flat reflectance v is
  (v, v, v) within 0.1% (0.999 v, as in Mitsuba); a colour outside
  [0, 1] is clipped into it, as Mitsuba clips it (with the one warning Mitsuba gives);
  a conductor's ``eta`` and ``k`` likewise under D65 but unbounded (only a negative channel
  is raised to 0);
- an **emitter's** radiance or intensity is an illuminant: no D65 weight, so a flat spectrum of
  1 is :data:`.xml_values.FLAT_EMITTER_RGB`; a negative channel is raised to 0, as Mitsuba.

The tables (``cie1931_d65.csv``, Mitsuba's nodes every 5 nm, linearly interpolated as Mitsuba
interpolates them) and the conductor presets (``conductors.csv``: :func:`conductor_preset`)
are written by ``tools/mitsuba_tables.py``.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

#: CIE XYZ to linear sRGB (IEC 61966-2-1), the matrix of Mitsuba's ``xyz_to_srgb``.
XYZ_TO_SRGB = np.array([[3.240479, -1.537150, -0.498535],
                        [-0.969256, 1.875991, 0.041556],
                        [0.055648, -0.204043, 1.057311]])
#: Mitsuba's range of the colour matching functions, nm.
CIE_MIN, CIE_MAX = 360.0, 830.0
#: Wavelengths Mitsuba's conversion sums over.
STEPS = 1000


@lru_cache(maxsize=1)
def _nodes() -> np.ndarray:
    path = Path(__file__).with_name("cie1931_d65.csv")
    return np.loadtxt(path, delimiter=",", comments="#")


def tables(wavelengths) -> np.ndarray:
    """(n, 4): x_bar, y_bar, z_bar and D65 at ``wavelengths`` (nm), zero outside 360 .. 830."""
    t = _nodes()
    w = np.asarray(wavelengths, dtype=np.float64)
    return np.column_stack([np.interp(w, t[:, 0], t[:, c], left=0.0, right=0.0)
                            for c in range(1, 5)])


def to_srgb(wavelengths, values, *, emitter: bool,
            unbounded: bool = False) -> tuple[np.ndarray, bool]:
    """(linear sRGB (3,), whether a channel was clipped) of the piecewise-linear spectrum
    through ``(wavelengths, values)`` (increasing wavelengths, nm); ``emitter``: an illuminant;
    ``unbounded``: not clipped above 1 (module docstring)."""
    wl = np.asarray(wavelengths, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    w = CIE_MIN + np.arange(STEPS) / (STEPS - 1) * (CIE_MAX - CIE_MIN)
    inside = (w >= wl[0]) & (w <= wl[-1])
    t = tables(w[inside])
    s = np.interp(w[inside], wl, v)
    weight = np.ones_like(s) if emitter else t[:, 3]
    xyz = (t[:, :3] * (s * weight)[:, None]).sum(axis=0) * (CIE_MAX - CIE_MIN) / STEPS
    rgb = XYZ_TO_SRGB @ (xyz / _y_integral())
    clipped = np.clip(rgb, 0.0, None if emitter or unbounded else 1.0)
    return clipped, bool((clipped != rgb).any())


@lru_cache(maxsize=1)
def _y_integral() -> float:
    """The Y function's integral by the same rule (Mitsuba's ``1 / MI_CIE_Y_NORMALIZATION``)."""
    w = CIE_MIN + np.arange(STEPS) / (STEPS - 1) * (CIE_MAX - CIE_MIN)
    return float(tables(w)[:, 1].sum() * (CIE_MAX - CIE_MIN) / STEPS)


@lru_cache(maxsize=1)
def _conductors() -> dict:
    path = Path(__file__).with_name("conductors.csv")
    out = {}
    for line in path.read_text().splitlines():
        if line and not line.startswith("#"):
            name, *values = line.split(",")
            out[name] = np.array(values, dtype=np.float64)
    return out


def conductor_preset(name: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(eta, k), each (3,) linear sRGB, of Mitsuba's conductor preset ``name`` (``Au``,
    ``Cu_palik``, ...), or None for a name Mitsuba does not have."""
    v = _conductors().get(name)
    return None if v is None else (v[:3].copy(), v[3:].copy())


def conductor_presets() -> list[str]:
    return list(_conductors())
