"""The camera's projection and its samples per pixel.

:class:`Pinhole` is the scene camera at an image size: it projects world points to
pixels (the light tracer's reference, :mod:`blockhash.reference.lighttrace`) and casts
rays through film points (the renderer's samples, :mod:`blockhash.frame.subpixel`), so
both integrate over the same pixel footprint.  :func:`spp_grid` lays a count of samples per
pixel out in stratified cells (rows x columns, as near square as the count allows).
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


def spp_grid(spp, name: str = "spp") -> tuple[int, int]:
    """``(rows, cols)`` of the stratified cells that ``spp`` samples per pixel fill, one sample
    a cell: ``rows`` the largest divisor of ``spp`` not above its square root, so a square
    number is S x S and any other count as near square as it divides (32: 4 x 8; a prime p:
    1 x p).  InputError outside 1 .. :data:`MAX_SPP`."""
    n = as_int(spp, name, minimum=1, maximum=MAX_SPP,
               hint=f"give 1 to {MAX_SPP} samples per pixel")
    rows = next(d for d in range(math.isqrt(n), 0, -1) if n % d == 0)
    return rows, n // rows


def grid_of(samples) -> tuple[int, int]:
    """``(rows, cols)`` of a sample layout given as S (S x S) or as ``(rows, cols)``."""
    if isinstance(samples, tuple):
        if len(samples) != 2:
            raise InputError(f"samples must be S or (rows, cols); got {samples!r}")
        return (as_int(samples[0], "sample rows", minimum=1),
                as_int(samples[1], "sample columns", minimum=1))
    s = as_int(samples, "samples", minimum=1, hint="use at least one shading point per pixel")
    return s, s


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
    #: The image's centre on the image plane (x right, y up), off the view axis for a crop.
    cx: float = 0.0
    cy: float = 0.0
    #: A thin lens: its radius (0: a pinhole) and the distance in focus along the view axis.
    aperture: float = 0.0
    focus: float = 1.0

    @classmethod
    def of(cls, camera, size=None) -> "Pinhole":
        width, height = size or (camera.width, camera.height)
        cam = replace(camera, width=width, height=height)
        right, up, forward = cam.basis()
        tan_x, tan_y, cx, cy = cam.window()
        return cls(np.asarray(cam.eye, np.float64), right, up, forward, tan_x, tan_y,
                   int(width), int(height), cx, cy, float(cam.aperture_radius),
                   float(cam.focus_distance))

    def lens_rays(self, x, y, seed: int):
        """(origins (m, 3), unit directions (m, 3)) of rays through film points ``(x, y)``
        from points of the thin lens (uniform on its disc, Shirley and Chiu's concentric map of
        stratum-free uniforms drawn with ``seed``) toward the points those film points see in
        focus, as Mitsuba's ``thinlens`` samples them; a pinhole's (:meth:`film_rays`) when
        the aperture is 0."""
        d = self.film_rays(x, y)
        if self.aperture <= 0.0:
            return np.broadcast_to(self.eye, d.shape).copy(), d
        u = self.lens_uniforms(len(d), seed)
        big = np.abs(u[:, 0]) > np.abs(u[:, 1])
        r = np.where(big, u[:, 0], u[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            phi = np.where(big, (np.pi / 4) * u[:, 1] / u[:, 0],
                           np.pi / 2 - (np.pi / 4) * u[:, 0] / u[:, 1])
        phi = np.nan_to_num(phi)
        lx, ly = self.aperture * r * np.cos(phi), self.aperture * r * np.sin(phi)
        origins = self.eye + lx[:, None] * self.right + ly[:, None] * self.up
        focus = self.eye + d * (self.focus / (d @ self.forward))[:, None]
        dirs = focus - origins
        return origins, dirs / np.linalg.norm(dirs, axis=1, keepdims=True)

    @staticmethod
    def lens_uniforms(m: int, seed: int) -> np.ndarray:
        """(m, 2) float64 uniforms in [-1, 1) of :meth:`lens_rays`' lens points, drawn with
        ``seed``."""
        return np.random.default_rng(seed).random((m, 2)) * 2.0 - 1.0

    @property
    def pixel_area(self) -> float:
        """Area of one pixel on the image plane at distance 1 from the pinhole."""
        return (2.0 * self.tan_x / self.width) * (2.0 * self.tan_y / self.height)

    def film_coords(self, points):
        """Film coordinates ``(x, y)`` in pixels of world points ((m, 3)), x from the left
        edge and y from the top as :meth:`film_rays` takes them, and their depth along the
        view axis ``z`` (the point is in front where z > 0)."""
        v = points - self.eye
        z = v @ self.forward
        with np.errstate(divide="ignore", invalid="ignore"):
            sx = ((v @ self.right) / z - self.cx) / self.tan_x
            sy = ((v @ self.up) / z - self.cy) / self.tan_y
        return (sx + 1.0) * 0.5 * self.width, (1.0 - sy) * 0.5 * self.height, z

    def project(self, points):
        """(pixel index (m,) int64, -1 outside the image; cos(theta_c) (m,)) of world points."""
        x, y, z = self.film_coords(points)
        col, row = np.floor(x), np.floor(y)  # row 0 at the top, like the renderer
        inside = (z > 0) & (col >= 0) & (col < self.width) & (row >= 0) & (row < self.height)
        pix = np.where(inside, row * self.width + col, -1)
        cos_c = np.where(inside, z / np.linalg.norm(points - self.eye, axis=1), 0.0)
        return np.nan_to_num(pix, nan=-1).astype(np.int64), cos_c

    def film_rays(self, x, y) -> np.ndarray:
        """(m, 3) unit view directions through film points (x, y) in pixels, x from the left
        edge and y from the top (pixel (row, col) covers [col, col + 1) x [row, row + 1),
        the footprint :meth:`project` assigns to it)."""
        sx = self.cx + (2.0 * np.ravel(x) / self.width - 1.0) * self.tan_x
        sy = self.cy + (1.0 - 2.0 * np.ravel(y) / self.height) * self.tan_y
        d = self.forward + sx[:, None] * self.right + sy[:, None] * self.up
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def pixel_rays(self) -> np.ndarray:
        """(h * w, 3) unit view directions through the pixel centres, row by row from the top."""
        gx, gy = np.meshgrid(np.arange(self.width) + 0.5, np.arange(self.height) + 0.5)
        return self.film_rays(gx, gy)


