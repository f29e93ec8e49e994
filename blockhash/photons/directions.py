"""Directions in cones: the geometry a light's photons are aimed with (:mod:`.emission`'s
point and spot lights, :mod:`.light_targets`' area and directional lights)."""

from __future__ import annotations

import numpy as np


def cone_solid_angle(cos_half: float | np.ndarray):
    """Solid angle (sr) of a cone with the given cosine of its half-angle."""
    return 2.0 * np.pi * (1.0 - np.asarray(cos_half, dtype=np.float64))


#: The direction every frame's first vector is made square to (:func:`frames`): oblique to the
#: scene's axes, so that no light above, beside or below a mirror has its axis near it.
REFERENCE = np.array([1.0, 2.0 ** 0.5, 3.0 ** 0.5]) / 6.0 ** 0.5
#: The second reference, for an axis within about 0.6 degrees of the first.
SECOND_REFERENCE = np.array([3.0 ** 0.5, -1.0, 2.0 ** 0.5]) / 6.0 ** 0.5
#: ``|REFERENCE x axis|`` below which the second reference is used.
NEAR_REFERENCE = 1e-2


def orthonormal_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,) completing unit ``axis`` to a right-handed frame
    (:func:`frames` of one row)."""
    t1, t2 = frames(np.asarray(axis, dtype=np.float64).reshape(1, 3))
    return t1[0], t2[0]


def frames(axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t1, t2) (n, 3): unit vectors completing each unit row of ``axes`` to a right-handed
    frame (t1, t2, axis), with t1 along ``REFERENCE x axis``.

    The frame turns continuously with its axis everywhere but within :data:`NEAR_REFERENCE` of
    the two poles +-:data:`REFERENCE`, so a photon's direction in a cone turns with the cone
    when a light moves (a frame built by the sign of the axis's z, Duff et al. 2017, turns
    half a circle where z changes sign: every photon of a light circling a mirror at its
    height would move from one frame to the next)."""
    axes = np.asarray(axes, dtype=np.float64)
    t1 = np.cross(REFERENCE, axes)
    length = np.linalg.norm(t1, axis=1)
    near = length < NEAR_REFERENCE
    if near.any():
        t1[near] = np.cross(SECOND_REFERENCE, axes[near])
        length[near] = np.linalg.norm(t1[near], axis=1)
    t1 /= length[:, None]
    return t1, np.cross(axes, t1)


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
