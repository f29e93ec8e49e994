"""A pass's pixels from its samples under the camera's pixel filter
(:class:`blockhash.scene.pixel_filter.PixelFilter`).

The box filter is the pixel mean of the samples inside the pixel
(:func:`blockhash.frame.subpixel.box_filter`).  A wider filter weighs every sample into the
pixels whose centres lie within its radius, and each pixel divides by the weight it received
(:func:`filtered`), as Mitsuba 3's film does, so that the filter blurs and never scales: a
flat image stays flat, at the borders too.

Photons splatted straight into pixels (:mod:`.pixel_splat`) stand for the radiance of a point
on the film, so :func:`spread` gives each the share a sample at that point would have had:
``f(c - x) * n / W(c)`` in pixel ``c``, ``n`` the samples a pixel and ``W(c)`` the weight the
pass's samples gave it, so the splat and the gathered samples of one pass are filtered alike.
"""

from __future__ import annotations

import math

import numpy as np

from blockhash.frame.subpixel import box_filter
from blockhash.scene.pixel_filter import PixelFilter


def _taps(pf: PixelFilter, x: np.ndarray, y: np.ndarray, width: int, height: int):
    """Per pixel offset a sample reaches: (flat pixel index, -1 outside; weight), each
    ``x``'s shape."""
    reach = max(0, math.ceil(pf.radius - 0.5))
    col0, row0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    for oy in range(-reach, reach + 1):
        row = row0 + oy
        wy = pf.weight(row + 0.5 - y)
        for ox in range(-reach, reach + 1):
            col = col0 + ox
            w = pf.weight(col + 0.5 - x) * wy
            inside = (row >= 0) & (row < height) & (col >= 0) & (col < width) & (w > 0)
            yield np.where(inside, row * width + col, -1), np.where(inside, w, 0.0)


def weights(pf: PixelFilter, x, y, width: int, height: int) -> np.ndarray:
    """(height * width,) float64: the weight each pixel receives from samples at ``(x, y)``."""
    total = np.zeros(width * height)
    for pix, w in _taps(pf, np.ravel(x), np.ravel(y), width, height):
        ok = pix >= 0
        total += np.bincount(pix[ok], w[ok], minlength=len(total))
    return total


def filtered(values: np.ndarray, x, y, pf: PixelFilter, width: int, height: int,
             samples=1, *, total: np.ndarray | None = None) -> np.ndarray:
    """(height, width, C) float32 pixels of ``values`` ((H', W', C) samples at film points
    ``(x, y)``, each (H', W')) under ``pf``; the box filter is the pixel mean of the ``samples``
    layout (S or (rows, cols)) exactly.  ``total``: the points' :func:`weights`, where the
    caller keeps them (else summed here)."""
    if pf.is_box:
        return box_filter(values, samples)
    v = np.asarray(values, dtype=np.float64).reshape(-1, values.shape[-1])
    acc = np.zeros((width * height, v.shape[1]))
    summed = np.zeros(width * height)
    for pix, w in _taps(pf, np.ravel(x), np.ravel(y), width, height):
        ok = pix >= 0
        if total is None:
            summed += np.bincount(pix[ok], w[ok], minlength=len(summed))
        for c in range(v.shape[1]):
            acc[:, c] += np.bincount(pix[ok], w[ok] * v[ok, c], minlength=len(acc))
    total = summed if total is None else total
    return (acc / total[:, None]).reshape(height, width, -1).astype(np.float32)


def spread(pf: PixelFilter, fx, fy, contrib: np.ndarray, width: int, height: int,
           share: np.ndarray, *, squared: bool = False) -> np.ndarray:
    """(height * width, 3) float64: ``contrib`` ((m, 3), each a point's pixel-mean radiance
    under a box) of points at film coordinates ``(fx, fy)`` spread by ``pf``, pixel ``c``
    taking ``f(c - x) * share[c]`` of each (``share``: the samples a pixel over the weight the
    pass gave it, module docstring, or :func:`continuous_share`); ``squared``: the sum of the
    squares of those shares of ``contrib`` (which holds the squares), for a variance."""
    image = np.zeros((width * height, 3))
    for pix, w in _taps(pf, np.asarray(fx, np.float64), np.asarray(fy, np.float64), width,
                        height):
        ok = pix >= 0
        ww = w[ok] * share[pix[ok]]
        if squared:
            ww = ww * ww
        for c in range(3):
            image[:, c] += np.bincount(pix[ok], ww * contrib[ok, c], minlength=len(image))
    return image


def continuous_share(pf: PixelFilter, width: int, height: int) -> np.ndarray:
    """(height * width,) float64: :func:`spread`'s ``share`` for points spread over the film
    with a uniform density (a light tracer's camera connections): one over the filter's
    integral over the film, ``1 / int f(c - x) dx`` for ``x`` inside the image (1 for the
    box; less than the whole filter's integral at the borders, as the film's own samples)."""
    steps = 256  # quadrature points a pixel
    reach = pf.radius
    t = (np.arange(-math.ceil(reach * steps), math.ceil(reach * steps)) + 0.5) / steps
    f = pf.weight(t)

    def axis(n: int) -> np.ndarray:
        x = (np.arange(n) + 0.5)[:, None] - t[None, :]
        return (f[None, :] * ((x >= 0) & (x <= n))).sum(axis=1) / steps

    return 1.0 / np.outer(axis(height), axis(width)).ravel()


class PassFilm:
    """The camera's pixel filter ``pf`` over the samples of a render's passes (``grid`` of
    them a pixel, laid out by :func:`blockhash.frame.subpixel.pass_points`) on the film of
    ``pin``: each pass's pixels (:meth:`develop`) and its pixel splat's spread
    (:meth:`spread`), the pass's sample points and weights kept for its layers."""

    def __init__(self, pin, pf: PixelFilter, grid):
        self.pin, self.pf, self.grid = pin, pf, grid
        self._pass = None

    def develop(self, values: np.ndarray, p: int) -> np.ndarray:
        """Pass ``p``'s pixels, (h, w, C) float32, of its samples' ``values`` (the layout of
        :func:`blockhash.frame.camera_samples.camera_samples`) under the filter."""
        if self.pf.is_box:
            return box_filter(values, self.grid)
        x, y, total, _ = self._points(p)
        return filtered(values, x, y, self.pf, self.pin.width, self.pin.height, total=total)

    def spread(self, p: int):
        """The pixel splat's ``spread`` for pass ``p`` (:func:`spread` under the filter; None
        for the box)."""
        if self.pf.is_box:
            return None
        share = self._points(p)[3]
        return lambda fx, fy, contrib: spread(self.pf, fx, fy, contrib, self.pin.width,
                                              self.pin.height, share)

    def _points(self, p: int):
        """Pass ``p``'s sample points, the weight each pixel receives from them, and each
        pixel's samples over that weight, computed once for the pass's layers."""
        if self._pass is None or self._pass[0] != p:
            from blockhash.frame.subpixel import pass_points

            rows, cols = self.grid
            x, y = pass_points(self.pin.width, self.pin.height, self.grid, p)
            w = weights(self.pf, x, y, self.pin.width, self.pin.height)
            self._pass = (p, x, y, w, rows * cols / w)
        return self._pass[1:]
