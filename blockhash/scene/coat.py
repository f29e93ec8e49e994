"""A diffuse surface under a dielectric coat: Mitsuba 3's ``plastic`` BSDF (a smooth coat) and
``roughplastic`` (a rough one) (:attr:`blockhash.scene.materials.PhongMaterial.coat`).

The coat of relative index ``eta`` reflects a ray arriving at ``cos`` to the normal with the
Fresnel reflectance F(cos) (a delta lobe, times the coat's ``coat_reflectance``), and the
base under it is a diffuse reflector seen through the coat:

    f(w_i, w_o) = kd (1 - F(cos_i)) (1 - F(cos_o)) / pi,    kd = base / (1 - F_dr) / eta^2

with F_dr the coat's diffuse reflectance from inside (:func:`fresnel_diffuse_reflectance`)
and ``base / (1 - base F_dr)`` in place of ``base / (1 - F_dr)`` for Mitsuba's ``nonlinear``.
``kd`` (:func:`coated_albedo`) is the Lambertian factor the receivers' tables hold; the two
transmittances ``1 - F`` (:func:`transmittance`) are the coat's: the camera's ray takes its
own on its weight, the direct light's shadow rays theirs, and a photon meets the coat's
reflection with probability F and the base otherwise, which carries its ``1 - F`` in
expectation.

A rough coat (``alpha`` > 0, Mitsuba's ``roughplastic``) reflects as a rough mirror of the
coat's index (:mod:`blockhash.scene.microfacet`: a conductor of ``eta`` and k = 0, times
``coat_reflectance``), and its two transmittances and F_dr are Mitsuba's tables of the rough
interface (:func:`blockhash.scene.coat_tables.rough_tables`): T(cos), the albedo of the
microfacet refraction into the coat at ``cos`` (Smith's shadowing on both directions),
tabulated at :data:`~blockhash.scene.coat_tables.NODES` cosines and interpolated linearly, in
place of 1 - F, and F_dr from the albedo of the microfacet reflection inside it.  A photon
meets the rough coat's reflection with probability 1 - T(cos): it reflects about a sampled
microfacet, its weight divided by 1 - T(cos); the base otherwise, which carries its T in
expectation.  (What the shadowing takes, 1 - R - T, the reflection's weight loses in
expectation, as Mitsuba's BSDF does.)
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.scene.coat_tables import NODES, rough_tables
from blockhash.scene.microfacet import ALPHA
from blockhash.scene.microfacet import fresnel as _fresnel

#: Columns of an object's row in the ray caster's table
#: (:attr:`blockhash.scene.raycast.EmbreeGeometry.mirror`) that hold its coat's index (0:
#: none), from the second its coat's reflectance (three), and from the third a rough coat's
#: transmittance at the :data:`~blockhash.scene.coat_tables.NODES` cosines (module docstring).
COAT, COAT_REFLECTANCE, COAT_TABLE = 12, 13, 16


def fresnel_diffuse_reflectance(eta):
    """The hemispherical mean of the Fresnel reflectance of an interface of relative index
    ``eta`` (the far side's index over the near side's, Mitsuba's convention: below 1 from
    inside a denser coat), by the fits Mitsuba 3 takes: Egan and Hilgeman's (1973) below 1,
    d'Eon and Irving's (2011) above."""
    eta = np.asarray(eta, dtype=np.float64)
    x = 1.0 / eta
    denser = -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 * x
    lighter = (0.919317 - 3.4793 * x + 6.75335 * x ** 2 - 7.80989 * x ** 3
               + 4.98554 * x ** 4 - 1.36881 * x ** 5)
    return np.where(eta < 1.0, denser, lighter)


def internal_reflectance(eta: float, alpha: float = 0.0, distribution: str = "beckmann") -> float:
    """F_dr: the coat's diffuse reflectance from inside (module docstring), smooth or rough."""
    if alpha > 0.0:
        return rough_tables(float(eta), float(alpha), distribution == "ggx")[1]
    return float(fresnel_diffuse_reflectance(1.0 / eta))


def coated_albedo(base, eta: float, nonlinear: bool = False, alpha: float = 0.0,
                  distribution: str = "beckmann") -> np.ndarray:
    """The Lambertian factor kd (module docstring) of a base reflectance ``base`` (any
    shape) under a coat of index ``eta`` (rough: ``alpha`` > 0 of ``distribution``)."""
    base = np.asarray(base, dtype=np.float64)
    fdr = internal_reflectance(eta, alpha, distribution)
    return base / (1.0 - (base * fdr if nonlinear else fdr)) / (eta * eta)


def base_reflectance(kd, eta: float, nonlinear: bool = False, alpha: float = 0.0,
                     distribution: str = "beckmann") -> np.ndarray:
    """The inverse of :func:`coated_albedo`: the base reflectance under the coat whose
    Lambertian factor is ``kd``."""
    x = np.asarray(kd, dtype=np.float64) * eta * eta
    fdr = internal_reflectance(eta, alpha, distribution)
    return x / (1.0 + x * fdr) if nonlinear else x * (1.0 - fdr)


def largest_albedo(eta: float, alpha: float = 0.0, distribution: str = "beckmann") -> float:
    """The largest Lambertian factor a coat of index ``eta`` gives (a white base)."""
    return float(coated_albedo(1.0, eta, alpha=alpha, distribution=distribution))


def transmittance(cos, table, obj) -> np.ndarray:
    """1 - F, or a rough coat's T (module docstring): what the coats of objects ``obj``
    let through of light arriving at ``cos`` to their normals from outside (0 where ``cos``
    <= 0, 1 without a coat); ``table`` the ray caster's per-object table."""
    cos = np.asarray(cos, dtype=np.float64)
    return _transmittances(np.ascontiguousarray(cos.reshape(-1)), table,
                           np.asarray(obj, dtype=np.int64).reshape(-1)).reshape(cos.shape)


@numba.njit(cache=True, nogil=True)
def _transmittances(cos, table, obj):
    out = np.empty(cos.shape[0])
    for j in range(cos.shape[0]):
        out[j] = through(cos[j], table, obj[j])
    return out


@numba.njit(cache=True, nogil=True, inline="always")
def through(cos, table, obj):
    """:func:`transmittance` of one ray, for the compiled callers."""
    eta = table[obj, COAT]
    if eta == 0.0:
        return 1.0
    if cos <= 0.0:
        return 0.0
    if table[obj, ALPHA] == 0.0:
        return 1.0 - _fresnel(cos, 1.0 / eta)
    x = min(cos, 1.0) * (NODES - 1)
    i = min(int(x), NODES - 2)
    f = x - i
    return (1.0 - f) * table[obj, COAT_TABLE + i] + f * table[obj, COAT_TABLE + i + 1]
