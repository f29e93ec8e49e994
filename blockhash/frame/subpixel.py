"""Shading points inside pixels: a regular grid or stratified jitter, by ray casting.

The G-buffer (:mod:`.gbuffer`) rasterises one shading point at the centre of each pixel;
rendered at ``S`` times the size and box-filtered, that is a regular S x S grid of
points per pixel.  A caustic much sharper than a pixel (a fold line of the cardioid on
the bust's chest, far thinner than a pixel at 128 x 128) then falls between the grid's
points or on them depending on its alignment, and the pixel mean a regular grid gives
is off by more than its count of points suggests (``docs/radiance-estimate.md``).

Stratified jitter removes that alignment: each pixel is cut into S x S equal cells and
each cell gets one point, uniform inside it.  The box-filtered mean is then an unbiased
estimate of the radiance's mean over the pixel's footprint, the quantity the light
tracer's reference (:mod:`blockhash.reference.lighttrace`) computes, whatever the caustic's shape; several
seeds give its sampling error.  The film points are those of :class:`blockhash.scene.camera.Pinhole`,
so the estimate and the reference integrate over the same footprint by construction.
"""

from __future__ import annotations

import numpy as np

from blockhash.errors import InputError
from blockhash.frame.gbuffer import GBuffer
from blockhash.scene.camera import SPP_SEED, Pinhole, grid_of, jitter_seed
from blockhash.validate import as_int


def box_filter(image: np.ndarray, samples) -> np.ndarray:
    """(h * rows, w * cols, ...) samples -> (h, w, ...) pixel means (the box filter), float32;
    ``samples`` the layout, S (S x S) or ``(rows, cols)``."""
    rows, cols = grid_of(samples)
    if rows == cols == 1:
        return np.asarray(image, dtype=np.float32)
    hs, ws = image.shape[:2]
    blocks = np.asarray(image).reshape(hs // rows, rows, ws // cols, cols, *image.shape[2:])
    # A float64 sum over each cell's samples, one strided slice at a time: no float64 copy of
    # the whole film (a few float32 samples add exactly in float64, so the order is free).
    total = np.zeros((hs // rows, ws // cols) + image.shape[2:])
    for i in range(rows):
        for j in range(cols):
            total += blocks[:, i, :, j]
    return (total / (rows * cols)).astype(np.float32)


def subpixel_points(width: int, height: int, samples, seed: int | None = None, *,
                    pixels=None):
    """Film coordinates ``(x, y)`` of rows x cols points per pixel, each
    (height * rows, width * cols); ``samples`` S (S x S) or ``(rows, cols)``
    (:func:`blockhash.scene.camera.spp_grid`).

    ``x`` runs from the left edge and ``y`` from the top, in pixels, so that pixel (row, col)
    covers [col, col + 1) x [row, row + 1).  Point (row * R + i, col * C + j) lies in cell
    (i, j) of pixel (row, col), the cell [col + j / C, col + (j + 1) / C) x [row + i / R, ...):
    at its centre when ``seed`` is None (the regular grid the rasteriser samples), else
    uniform inside it (stratified jitter), the same points for the same seed.

    ``pixels`` ((P, 2) ints, rows and columns): only those pixels, (P * R, C), the points of
    pixel p in rows p * R to p * R + R - 1 (cell (i, j) at row p * R + i, column j).
    """
    width = as_int(width, "width", minimum=1)
    height = as_int(height, "height", minimum=1)
    r, c = grid_of(samples)
    if pixels is None:
        rows = np.repeat(np.arange(height), r)[:, None]
        cols = np.repeat(np.arange(width), c)[None, :]
        shape = (height * r, width * c)
    else:
        px = np.asarray(pixels, dtype=np.int64).reshape(-1, 2)
        if (px < 0).any() or (px[:, 0] >= height).any() or (px[:, 1] >= width).any():
            raise InputError(f"pixels must lie inside the {width} x {height} image")
        rows = np.repeat(px[:, 0], r)[:, None]
        cols = np.broadcast_to(px[:, 1].repeat(r)[:, None], (len(px) * r, 1))
        shape = (len(px) * r, c)
    i = (np.arange(shape[0]) % r)[:, None]
    j = (np.arange(shape[1]) % c)[None, :]
    if seed is None:
        u = v = np.full(shape, 0.5)
    else:
        rng = np.random.default_rng(as_int(seed, "seed", minimum=0))
        u, v = rng.random(shape), rng.random(shape)
    return cols + (j + u) / c, rows + (i + v) / r


def raycast_gbuffer(camera, rays, *, size=None, samples=1, seed: int | None = None,
                    pixels=None) -> GBuffer:
    """The G-buffer of :func:`.gbuffer.rasterize` at (width * cols, height * rows), by ray
    casting through :func:`subpixel_points` (``samples`` S or ``(rows, cols)``; ``rays`` a
    :class:`.scene_rays.SceneRays` of the scene); with ``pixels``, only theirs, (P * rows, cols)
    as :func:`subpixel_points` lays them out.

    Normals face the camera as the rasteriser turns them; rays that miss get object -1.
    """

    pin = Pinhole.of(camera, size)
    x, y = subpixel_points(pin.width, pin.height, samples, seed, pixels=pixels)
    return film_gbuffer(pin, rays, x, y, lens_seed=LENS_KEY + (seed or 0))


#: Offset of the lens samples' seed from the film samples' (a stream of their own).
LENS_KEY = 0x5DEECE66D


#: Rays cast together by :func:`film_gbuffer`: its temporaries, about ten (rays, 3) float64
#: arrays (origins, directions, points, normals and their hit subsets, 24 bytes a ray each),
#: stay a few MiB whatever the film, where a whole film's held them all at once (14 MiB each
#: for a 256 x 256 film at 3 x 3 samples, 589,824 rays).
CHUNK_RAYS = 1 << 15


def film_gbuffer(pin: Pinhole, rays, x: np.ndarray, y: np.ndarray, *,
                 lens_seed: int = LENS_KEY) -> GBuffer:
    """The G-buffer of the rays through film points ``(x, y)`` (pixels from the top left,
    any shape), by ray casting, :data:`CHUNK_RAYS` rays at a time; where ``rays`` cast on a
    device, the rays are made and cast there (:meth:`blockhash.device.rays.DeviceCasts.film_hits`)."""
    if rays.device is not None:
        lens = pin.lens_uniforms(x.size, lens_seed) if pin.aperture > 0 else None
        position, normal, obj, front, o = rays.device.film_hits(pin, x.reshape(-1), y.reshape(-1),
                                                                lens)
        return GBuffer(position=position.reshape(*x.shape, 3), normal=normal.reshape(*x.shape, 3),
                       object=obj.reshape(x.shape), front=front.reshape(x.shape),
                       origin=o.reshape(*x.shape, 3) if o is not None else None)
    o, d = pin.lens_rays(x, y, lens_seed)
    shape, m = x.shape, len(d)
    position, normal = np.empty((m, 3), np.float32), np.empty((m, 3), np.float32)
    obj, front = np.empty(m, np.int32), np.empty(m, bool)
    for start in range(0, m, CHUNK_RAYS):
        s = slice(start, start + CHUNK_RAYS)
        hit, p, n, o_id, _, front[s] = rays.first_hit(o[s], d[s], sides=True)
        p[~hit] = o[s][~hit] + d[s][~hit]  # a miss: a point one unit along its ray (GBuffer)
        n[np.einsum("ij,ij->i", n, d[s]) > 0] *= -1.0
        position[s], normal[s], obj[s] = p, n, np.where(hit, o_id, -1)
    return GBuffer(position=position.reshape(*shape, 3), normal=normal.reshape(*shape, 3),
                   object=obj.reshape(shape), front=front.reshape(shape),
                   origin=o.reshape(*shape, 3) if pin.aperture > 0 else None)


#: The R2 sequence's steps (Roberts 2018): 1 / g and 1 / g^2 for the plastic number g, the
#: two-dimensional generalisation of the golden ratio's additive recurrence.
R2_STEP = (0.7548776662466927, 0.5698402909980532)


def pass_offsets(width: int, height: int, pass_index: int, seed: int):
    """``(u, v)``, (height, width) offsets in [0, 1) of pass ``pass_index``'s one camera
    sample in each pixel.

    Pixel by pixel the passes run through the R2 sequence ``frac(shift + p * R2_STEP)``,
    low-discrepancy over the passes (any run of n passes covers the pixel about as evenly as
    an n-point stratified pattern), under a random shift of each pixel's own (Cranley and
    Patterson 1976; drawn from ``seed``), so that every sample is uniform in its pixel (the
    pixel mean stays unbiased) and neighbouring pixels do not share one pattern.
    """
    rng = np.random.default_rng(as_int(seed, "seed", minimum=0))
    shift = rng.random((2, height, width))
    p = as_int(pass_index, "pass_index", minimum=0)
    u = np.mod(shift[0] + p * R2_STEP[0], 1.0)
    v = np.mod(shift[1] + p * R2_STEP[1], 1.0)
    return u, v


def pass_points(width: int, height: int, samples, pass_index: int):
    """Film coordinates ``(x, y)`` of pass ``pass_index``'s samples, as
    :func:`blockhash.frame.camera_samples.camera_samples` casts them (``samples`` S or
    (rows, cols)): the pixel centres for one
    sample in pass 0 (the rasteriser's), the pass's R2 offsets for one sample in a later pass,
    else the pass's stratified jitter."""
    rows, cols = grid_of(samples)
    if rows == cols == 1 and pass_index == 0:
        return subpixel_points(width, height, 1)
    if rows == cols == 1:
        u, v = pass_offsets(width, height, pass_index, SPP_SEED)
        return np.arange(width)[None, :] + u, np.arange(height)[:, None] + v
    return subpixel_points(width, height, (rows, cols), jitter_seed(pass_index))
