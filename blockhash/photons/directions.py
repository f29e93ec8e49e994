"""Directions in cones: the geometry a light's photons are aimed with (:mod:`.emission`'s
point and spot lights, :mod:`.light_targets`' area and directional lights)."""

from __future__ import annotations

import numpy as np


def cone_solid_angle(cos_half: float | np.ndarray):
    """Solid angle (sr) of a cone with the given cosine of its half-angle."""
    return 2.0 * np.pi * (1.0 - np.asarray(cos_half, dtype=np.float64))


def orthonormal_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,) completing unit ``axis`` to a right-handed frame (Duff et al. 2017)."""
    x, y, z = (float(c) for c in axis)
    sign = 1.0 if z >= 0.0 else -1.0
    a = -1.0 / (sign + z)
    b = x * y * a
    t1 = np.array([1.0 + sign * x * x * a, sign * b, -sign * x])
    t2 = np.array([b, sign + y * y * a, -y])
    return t1, t2


def frames(axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t1, t2) (n, 3): unit vectors completing each unit row of ``axes`` to a right-handed
    frame (:func:`blockhash.photons.emission.orthonormal_basis`, row by row)."""
    x, y, z = axes[:, 0], axes[:, 1], axes[:, 2]
    sign = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    t1 = np.stack([1.0 + sign * x * x * a, sign * b, -sign * x], axis=1)
    t2 = np.stack([b, sign + y * y * a, -y], axis=1)
    return t1, t2


def sample_cones(axes, t1, t2, cos_half, u1, u2) -> np.ndarray:
    """(n, 3) directions uniform in solid angle inside per-photon cones.

    ``axes``, ``t1``, ``t2`` are (n, 3) orthonormal frames, ``cos_half`` (n,) (or one frame
    and half-angle for all, (1, 3) and (1,)), ``u1``, ``u2`` (n,) uniforms in [0, 1).
    """
    cos_t = 1.0 - u1 * (1.0 - cos_half)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
    phi = 2.0 * np.pi * u2
    d = (cos_t[:, None] * axes + (sin_t * np.cos(phi))[:, None] * t1
         + (sin_t * np.sin(phi))[:, None] * t2)
    return d / np.linalg.norm(d, axis=1, keepdims=True)
