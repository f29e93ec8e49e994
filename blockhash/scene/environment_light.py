"""Light from an environment map: radiance arriving from infinitely far, by direction, read from
a latitude-longitude image as Mitsuba 3's ``envmap`` emitter reads it (:class:`EnvironmentLight`).

**Directions.**  A world direction ``w`` toward the environment is taken to the map's frame by
the inverse of ``to_world`` (a rotation), ``v = R^T w``, and to texture coordinates
``u = atan2(v_x, -v_z) / 2 pi`` (wrapped to [0, 1)), ``t = acos(v_y) / pi``: the image's first
row is the map's +y pole and its last row the -y pole, and the columns run around y.
**Radiance** is the image's bilinear interpolation at pixel coordinates
``x = frac(u - 1 / 2W) W`` (column W wraps to column 0), ``y = t (H - 1)``, times ``scale``,
as Mitsuba's RGB variants evaluate it.

**Sampling.**  The bilinear cells (W columns, H - 1 rows, each between four pixels) are
chosen with probability proportional to the mean luminance of their corners times their solid
angle (a row of cells first, then a cell in the row); within a cell the direction is uniform in solid angle (``x`` uniform, ``cos theta``
uniform across the cell's band), so the density per steradian is constant over a cell,
``P_cell / Omega_cell``, and finite at the poles.  A cell whose corners are all black is never
chosen, and the bilinear radiance is zero everywhere in it: the estimate ``L(w) / p(w)`` is
unbiased whatever the map.  The host's numpy and the device's Dr.Jit kernels
(:mod:`blockhash.device.environment`) sample the same tables by the same rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from blockhash.scene.values import FieldError as _FieldError
from blockhash.scene.values import owned as _owned
from blockhash.scene.values import readonly as _readonly

#: Rec. 709 luminance weights, as Mitsuba's ``luminance()`` (the sampling's importance).
LUMINANCE = np.array([0.212671, 0.715160, 0.072169])
#: How far from orthonormal ``to_world``'s 3 x 3 part may be (a rotation, as Mitsuba's
#: directions need: a scale would change their length and the map's latitudes).
ROTATION_TOL = 1e-4


@dataclass(frozen=True, eq=False)
class EnvironmentLight:
    """An environment map: ``image`` (H, W, 3) linear RGB radiance in W m^-2 sr^-1 (already
    times its scale), ``to_world`` (3, 3) the rotation from the map's frame to the world's,
    ``name`` what errors and summaries call it (module docstring for the mapping)."""

    image: np.ndarray
    to_world: np.ndarray = None
    name: str = "environment"

    def __post_init__(self):
        with _owned(f"EnvironmentLight {self.name!r}"):
            img = np.asarray(self.image, dtype=np.float64)
            if img.ndim != 3 or img.shape[2] != 3:
                raise _FieldError("image", f"expected (height, width, 3) RGB radiance; got shape "
                                  f"{img.shape}")
            if img.shape[0] < 3 or img.shape[1] < 2:
                raise _FieldError("image", f"the map is {img.shape[1]} x {img.shape[0]} pixels; "
                                  "a latitude-longitude map needs at least 2 x 3 (as Mitsuba's)")
            bad = ~np.isfinite(img)
            if bad.any() or (img < 0).any():
                what = (f"{int(bad.sum()):,} values not finite" if bad.any()
                        else f"{int((img < 0).sum()):,} values below 0")
                raise _FieldError("image", f"{what}; radiance must be finite and >= 0: fix the "
                                  "image (e.g. clamp it where it was made)")
            R = np.eye(3) if self.to_world is None else np.asarray(self.to_world, np.float64)
            if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=ROTATION_TOL) \
                    or np.linalg.det(R) < 0:
                raise _FieldError("to_world", "expected a rotation (3 x 3, orthonormal, no "
                                  "mirror flip): an environment map turns, it has no position "
                                  "or scale; drop the scale from its transform")
            object.__setattr__(self, "image", _readonly(img))
            object.__setattr__(self, "to_world", _readonly(R))
            self._tables()

    def _tables(self):
        img = self.image
        h, w = img.shape[:2]
        rgb = 0.25 * (img[:-1] + np.roll(img, -1, axis=1)[:-1] + img[1:]
                      + np.roll(img, -1, axis=1)[1:])  # (H - 1, W, 3) each cell's corners' mean
        corners = rgb @ LUMINANCE
        cos_edge = np.cos(np.arange(h) * (math.pi / (h - 1)))
        band = cos_edge[:-1] - cos_edge[1:]  # each row of cells' share of 2 (the sphere / 2 pi)
        omega = (2.0 * math.pi / w) * band  # (H - 1,) steradians of one cell of the row
        mass = corners * omega[:, None]
        total = float(mass.sum())
        if not total > 0.0:
            raise _FieldError("image", "the map is black (no radiance anywhere); an "
                              "environment light must emit somewhere")
        pmf = (mass / total).reshape(-1)
        row_pmf = mass.sum(axis=1) / total
        row_cdf = np.cumsum(row_pmf)
        row_cdf[-1] = 1.0
        row_mass = mass.sum(axis=1, keepdims=True)
        col_cdf = np.cumsum(mass, axis=1) / np.where(row_mass > 0.0, row_mass, 1.0)
        col_cdf[:, -1] = 1.0
        object.__setattr__(self, "_pmf", _readonly(pmf))
        object.__setattr__(self, "_row_cdf", _readonly(row_cdf))
        object.__setattr__(self, "_col_cdf", _readonly(col_cdf))
        object.__setattr__(self, "_col_flat", _readonly(
            (col_cdf + np.arange(h - 1)[:, None]).reshape(-1)))
        object.__setattr__(self, "_cos_edge", _readonly(cos_edge))
        object.__setattr__(self, "_omega", _readonly(omega))
        object.__setattr__(self, "_integral", _readonly(
            np.einsum("ijc,i->c", rgb, omega)))

    # ------------------------------------------------------------------ tables

    @property
    def cell_pmf(self) -> np.ndarray:
        """(W (H - 1),) each bilinear cell's probability, row by row from the +y pole."""
        return self._pmf

    @property
    def row_cdf(self) -> np.ndarray:
        """(H - 1,) the rows of cells' cumulative probability (the last 1)."""
        return self._row_cdf

    @property
    def column_cdf(self) -> np.ndarray:
        """(H - 1, W) within each row, its cells' cumulative probability (the last 1)."""
        return self._col_cdf

    @property
    def band_cos(self) -> np.ndarray:
        """(H,) cos theta at each pixel row (the cells' edges in latitude)."""
        return self._cos_edge

    @property
    def cell_solid_angle(self) -> np.ndarray:
        """(H - 1,) steradians of one cell of each row."""
        return self._omega

    @property
    def integral(self) -> np.ndarray:
        """(3,) W m^-2: the radiance integrated over the sphere (each cell's corners' mean
        times its solid angle): the irradiance a disc facing every way at once would take;
        times pi r^2, the watts that cross a sphere of radius r."""
        return self._integral

    # ------------------------------------------------------------------ evaluation

    def emitted(self, toward: np.ndarray) -> np.ndarray:
        """(n, 3) radiance arriving from the environment along each world direction
        ``toward`` (n, 3) (unit, pointing from the scene out to the map; module docstring)."""
        x, y, i, j = self._cells_of(toward)
        w = self.image.shape[1]
        fx, fy = (x - i)[:, None], (y - j)[:, None]
        i1 = (i + 1) % w
        img = self.image
        top = img[j, i] * (1.0 - fx) + img[j, i1] * fx
        bottom = img[j + 1, i] * (1.0 - fx) + img[j + 1, i1] * fx
        return top * (1.0 - fy) + bottom * fy

    def sample(self, u0: np.ndarray, u1: np.ndarray | None, u2: np.ndarray):
        """(directions toward the map (n, 3), density per steradian (n,)) from uniforms: the
        row of cells by ``u0`` on :attr:`row_cdf`, the cell in it by ``u1`` on its
        :attr:`column_cdf` (the remainder of ``u1`` in the cell's stretch, rescaled, across
        the cell's column), then ``u2`` across its band of cos theta (module docstring).
        ``u1`` None: ``u0``'s remainder in its row's stretch takes its place (two uniforms a
        direction, as the shading points' light samples come).  Row, then column: each
        table is short, so a map of millions of cells keeps every cell's share in float32 on
        the device (:mod:`blockhash.device.environment`)."""
        h, w = self.image.shape[:2]
        u0 = np.asarray(u0, dtype=np.float64)
        j, rest = _pick(self._row_cdf, u0)
        u1 = rest if u1 is None else np.asarray(u1, dtype=np.float64)
        # each row's cdf shifted by its row number: one sorted table for every row's search
        flat = np.searchsorted(self._col_flat, j + u1, side="right")
        i = np.clip(flat - j * w, 0, w - 1)
        cols = self._col_cdf.reshape(-1)
        lo = np.where(i > 0, cols[j * w + np.maximum(i - 1, 0)], 0.0)
        width = np.maximum(cols[j * w + i] - lo, 1e-300)
        across = np.clip((u1 - lo) / width, 0.0, 1.0 - 1e-12)
        phi = 2.0 * math.pi * ((i + across) / w + 0.5 / w)
        c0, c1 = self._cos_edge[j], self._cos_edge[j + 1]
        cos_t = np.clip(c0 - np.asarray(u2) * (c0 - c1), -1.0, 1.0)
        sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
        v = np.stack([np.sin(phi) * sin_t, cos_t, -np.cos(phi) * sin_t], axis=1)
        return v @ self.to_world.T, self._pmf[j * w + i] / self._omega[j]

    def pdf(self, toward: np.ndarray) -> np.ndarray:
        """(n,) the density per steradian :meth:`sample` draws each direction ``toward`` with."""
        _, _, i, j = self._cells_of(toward)
        return self._pmf[j * self.image.shape[1] + i] / self._omega[j]

    def _cells_of(self, toward: np.ndarray):
        """(x, y, column i, row j): the pixel coordinates of world directions ``toward`` and
        the bilinear cell that holds them (module docstring)."""
        v = np.asarray(toward, dtype=np.float64) @ self.to_world  # R^T w, row by row
        h, w = self.image.shape[:2]
        u = np.arctan2(v[:, 0], -v[:, 2]) / (2.0 * math.pi) - 0.5 / w
        x = (u - np.floor(u)) * w
        y = np.arccos(np.clip(v[:, 1], -1.0, 1.0)) / math.pi * (h - 1)
        return x, y, np.minimum(x.astype(np.int64), w - 1), np.minimum(y.astype(np.int64), h - 2)

    def __repr__(self) -> str:
        h, w = self.image.shape[:2]
        return (f"EnvironmentLight(name={self.name!r}, {w} x {h} pixels, integral="
                f"{np.array2string(self.integral, precision=4)} W/m^2)")


def _pick(cdf: np.ndarray, u: np.ndarray):
    """(the entry of ``cdf`` whose stretch holds each uniform ``u``, the uniform's remainder
    in that stretch rescaled to [0, 1))."""
    k = np.minimum(np.searchsorted(cdf, u, side="right"), len(cdf) - 1)
    lo = np.where(k > 0, cdf[np.maximum(k - 1, 0)], 0.0)
    rest = np.clip((u - lo) / np.maximum(cdf[k] - lo, 1e-300), 0.0, 1.0 - 1e-12)
    return k, rest
