"""A synthetic environment map for the tests: a sky brighter toward its pole, a small sun far
brighter than the rest and a black band (cells the sampling never chooses), turned off the
axes so that no symmetry hides a wrong turn."""

from __future__ import annotations

import numpy as np

from blockhash.scene.environment_light import EnvironmentLight


def rotation(yaw: float = 0.7, pitch: float = 0.4) -> np.ndarray:
    """A rotation about y by ``yaw`` then about x by ``pitch`` (radians)."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    about_y = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    about_x = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    return about_x @ about_y


def sky_image(width: int = 32, height: int = 17) -> np.ndarray:
    """(height, width, 3) radiance: a gradient from the +y pole, a black band below the
    horizon's first rows, a 2 x 2 pixel sun 200 times the sky."""
    rows = np.linspace(1.0, 0.2, height)[:, None, None]
    img = np.broadcast_to(rows * np.array([0.6, 0.8, 1.0]), (height, width, 3)).copy()
    img[height // 2 + 1:height // 2 + 3] = 0.0
    img[3:5, 5:7] = np.array([200.0, 180.0, 150.0])
    return img


def sky(scale: float = 1.0, to_world=None) -> EnvironmentLight:
    """The synthetic sky as an :class:`EnvironmentLight` (turned by :func:`rotation`)."""
    return EnvironmentLight(sky_image() * scale, rotation() if to_world is None else to_world,
                            name="sky")
