"""The camera's projection and its samples per pixel.

:class:`Pinhole` is the scene camera at an image size: it projects world points to
pixels (the light tracer's reference, :mod:`blockhash.reference.lighttrace`) and casts
rays through film points (the renderer's samples, :mod:`blockhash.frame.subpixel`), so
both integrate over the same pixel footprint.  :func:`spp_side` checks a count of samples
per pixel (stratified S x S).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from blockhash.errors import InputError
from blockhash.validate import as_int

#: Samples per pixel of a render unless the call or the scene's ``[camera] spp`` says
#: otherwise; chosen by measurement (BENCHMARKS.md, "Samples per pixel").
DEFAULT_SPP = 9
#: Most samples per pixel (a 32 x 32 grid).
MAX_SPP = 1024
#: The jitter pattern of every render: fixed, so that an image is the same in every run and
#: on every backend (the points are cast on the CPU).
SPP_SEED = 20020901


def jitter_seed(index: int) -> int:
    """The stratified jitter's seed of render pass (or repeat) ``index``: :data:`SPP_SEED`
    for the first, another of its own for each later one."""
    return SPP_SEED if index == 0 else SPP_SEED + 7919 * int(index)


def spp_side(spp, name: str = "spp") -> int:
    """S for ``spp = S * S`` samples per pixel (stratified in S x S cells); InputError for
    anything else."""
    n = as_int(spp, name, minimum=1, maximum=MAX_SPP,
               hint="give a square number of samples per pixel: 1, 4, 9, 16, ...")
    side = math.isqrt(n)
    if side * side != n:
        raise InputError(f"{name}={n} is not a square number; samples are stratified in S x S "
                         f"cells per pixel, so use {side * side} or {(side + 1) ** 2}")
    return side


@dataclass(frozen=True)
class Pinhole:
    """The scene camera at a given image size: projection and importance (see module docstring)."""

    eye: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    tan_x: float
    tan_y: float
    width: int
    height: int

    @classmethod
    def of(cls, camera, size=None) -> "Pinhole":
        width, height = size or (camera.width, camera.height)
        cam = replace(camera, width=width, height=height)
        right, up, forward = cam.basis()
        tan_y = math.tan(math.radians(cam.fov_y_deg) / 2.0)
        return cls(np.asarray(cam.eye, np.float64), right, up, forward, tan_y * cam.aspect, tan_y,
                   int(width), int(height))

    @property
    def pixel_area(self) -> float:
        """Area of one pixel on the image plane at distance 1 from the pinhole."""
        return (2.0 * self.tan_x / self.width) * (2.0 * self.tan_y / self.height)

    def project(self, points):
        """(pixel index (m,) int64, -1 outside the image; cos(theta_c) (m,)) of world points."""
        v = points - self.eye
        z = v @ self.forward
        with np.errstate(divide="ignore", invalid="ignore"):
            sx = (v @ self.right) / (z * self.tan_x)
            sy = (v @ self.up) / (z * self.tan_y)
        col = np.floor((sx + 1.0) * 0.5 * self.width)
        row = np.floor((1.0 - sy) * 0.5 * self.height)  # row 0 at the top, like the renderer
        inside = (z > 0) & (col >= 0) & (col < self.width) & (row >= 0) & (row < self.height)
        pix = np.where(inside, row * self.width + col, -1)
        cos_c = np.where(inside, z / np.linalg.norm(v, axis=1), 0.0)
        return np.nan_to_num(pix, nan=-1).astype(np.int64), cos_c

    def film_rays(self, x, y) -> np.ndarray:
        """(m, 3) unit view directions through film points (x, y) in pixels, x from the left
        edge and y from the top (pixel (row, col) covers [col, col + 1) x [row, row + 1),
        the footprint :meth:`project` assigns to it)."""
        sx = (2.0 * np.ravel(x) / self.width - 1.0) * self.tan_x
        sy = (1.0 - 2.0 * np.ravel(y) / self.height) * self.tan_y
        d = self.forward + sx[:, None] * self.right + sy[:, None] * self.up
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def pixel_rays(self) -> np.ndarray:
        """(h * w, 3) unit view directions through the pixel centres, row by row from the top."""
        gx, gy = np.meshgrid(np.arange(self.width) + 0.5, np.arange(self.height) + 0.5)
        return self.film_rays(gx, gy)


