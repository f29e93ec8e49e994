"""A diffuse surface under a smooth dielectric coat: Mitsuba 3's ``plastic`` BSDF
(:attr:`blockhash.scene.materials.PhongMaterial.coat`).

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
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.scene.microfacet import fresnel as _fresnel
from blockhash.scene.optics import fresnel

#: Columns of an object's row in the ray caster's table
#: (:attr:`blockhash.scene.raycast.EmbreeGeometry.mirror`) that hold its coat's index (0:
#: none) and, from the second, its coat's reflectance (three).
COAT, COAT_REFLECTANCE = 12, 13


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


def coated_albedo(base, eta: float, nonlinear: bool = False) -> np.ndarray:
    """The Lambertian factor kd (module docstring) of a base reflectance ``base`` (any
    shape) under a coat of index ``eta``."""
    base = np.asarray(base, dtype=np.float64)
    fdr = float(fresnel_diffuse_reflectance(1.0 / eta))
    return base / (1.0 - (base * fdr if nonlinear else fdr)) / (eta * eta)


def base_reflectance(kd, eta: float, nonlinear: bool = False) -> np.ndarray:
    """The inverse of :func:`coated_albedo`: the base reflectance under the coat whose
    Lambertian factor is ``kd``."""
    x = np.asarray(kd, dtype=np.float64) * eta * eta
    fdr = float(fresnel_diffuse_reflectance(1.0 / eta))
    return x / (1.0 + x * fdr) if nonlinear else x * (1.0 - fdr)


def largest_albedo(eta: float) -> float:
    """The largest Lambertian factor a coat of index ``eta`` gives (a white base)."""
    return float(coated_albedo(1.0, eta))


def transmittance(cos, eta) -> np.ndarray:
    """1 - F: what a coat of index ``eta`` lets through of light arriving at ``cos`` to its
    normal from outside (0 where ``cos`` <= 0)."""
    cos = np.asarray(cos, dtype=np.float64)
    return np.where(cos > 0.0, 1.0 - fresnel(np.clip(cos, 0.0, 1.0), 1.0 / np.asarray(eta)), 0.0)


@numba.njit(cache=True, nogil=True, inline="always")
def through(cos, eta):
    """:func:`transmittance` of one ray, for the compiled callers: 1 where ``eta`` is 0 (no
    coat)."""
    return 1.0 if eta == 0.0 else 1.0 - _fresnel(cos, 1.0 / eta)
