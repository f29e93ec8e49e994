"""Image textures: :class:`Texture`, a reflectance that varies over a surface, looked up at the
surface's texture coordinates as Mitsuba 3's ``bitmap`` texture looks it up; :func:`read_image`,
an image file as linear RGB.

**Lookup.**  Texture coordinates (u, v) are first mapped by ``to_uv`` (an affine map), then
taken to pixel coordinates ``x = u W - 1/2``, ``y = v H - 1/2`` (pixel centres at half-integers;
the image's first row at v = 0, as Mitsuba reads it), wrapped (``repeat``, ``mirror`` or
``clamp``) and filtered (``bilinear`` between the four nearest pixels, or ``nearest``).

**Where it is used.**  A textured diffuse material (:class:`blockhash.scene.materials.
PhongMaterial` with ``texture``) keeps the texture's mean as its ``kd``; each shading point on
it scales its path weight by the texture's value over that mean (its direct light, caustic
and indirect estimates are all proportional to the reflectance), and each indirect photon
that bounces off it takes the texture's value at its hit as its albedo.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockhash.errors import InputError
from blockhash.scene.values import FieldError as _FieldError
from blockhash.scene.values import owned as _owned
from blockhash.scene.values import readonly as _readonly

WRAPS = ("repeat", "mirror", "clamp")
FILTERS = ("bilinear", "nearest")


@dataclass(frozen=True, eq=False)
class Texture:
    """``image`` (H, W, 3) linear RGB in [0, 1] (>= 0 where not ``bounded``), ``to_uv`` (2, 3)
    the affine map of the texture
    coordinates (None: the identity), ``wrap`` one of :data:`WRAPS`, ``filter`` one of
    :data:`FILTERS`; ``name`` what errors and summaries call it (module docstring)."""

    image: np.ndarray
    to_uv: np.ndarray = None
    wrap: str = "repeat"
    filter: str = "bilinear"
    name: str = "texture"
    #: A reflectance's values lie in [0, 1]; a light's (a spot light's texture) are only >= 0.
    bounded: bool = True

    def __post_init__(self):
        with _owned(f"Texture {self.name!r}"):
            img = np.asarray(self.image, dtype=np.float64)
            if img.ndim != 3 or img.shape[2] != 3 or min(img.shape[:2]) < 1:
                raise _FieldError("image", f"expected (height, width, 3) RGB; got shape {img.shape}")
            if not np.isfinite(img).all() or (img < 0).any() or (self.bounded and (img > 1).any()):
                raise _FieldError("image", "a reflectance texture's values must lie in [0, 1]; "
                                  "fix the image (a reflectance above 1 would make light)"
                                  if self.bounded else "a light's texture must be finite and "
                                  ">= 0; fix the image")
            m = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]) if self.to_uv is None \
                else np.asarray(self.to_uv, dtype=np.float64)
            if m.shape != (2, 3) or not np.isfinite(m).all():
                raise _FieldError("to_uv", f"expected a (2, 3) affine map; got shape {m.shape}")
            if self.wrap not in WRAPS:
                raise _FieldError("wrap", f"expected one of {', '.join(WRAPS)}; got {self.wrap!r}")
            if self.filter not in FILTERS:
                raise _FieldError("filter", f"expected one of {', '.join(FILTERS)}; got "
                                  f"{self.filter!r}")
            object.__setattr__(self, "image", _readonly(img))
            object.__setattr__(self, "to_uv", _readonly(m))

    @property
    def mean(self) -> np.ndarray:
        """(3,) the image's mean: a textured material's ``kd``."""
        return self.image.mean(axis=(0, 1))

    def value(self, uv: np.ndarray) -> np.ndarray:
        """(n, 3) the texture at texture coordinates ``uv`` (n, 2) (module docstring)."""
        uv = np.asarray(uv, dtype=np.float64) @ self.to_uv[:, :2].T + self.to_uv[:, 2]
        h, w = self.image.shape[:2]
        img = self.image
        if self.filter == "nearest":
            i = self._wrap(np.floor(uv[:, 0] * w).astype(np.int64), w)
            j = self._wrap(np.floor(uv[:, 1] * h).astype(np.int64), h)
            return img[j, i]
        x, y = uv[:, 0] * w - 0.5, uv[:, 1] * h - 0.5
        i0, j0 = np.floor(x), np.floor(y)
        fx, fy = (x - i0)[:, None], (y - j0)[:, None]
        i0, j0 = i0.astype(np.int64), j0.astype(np.int64)
        i1, j1 = self._wrap(i0 + 1, w), self._wrap(j0 + 1, h)
        i0, j0 = self._wrap(i0, w), self._wrap(j0, h)
        top = img[j0, i0] * (1.0 - fx) + img[j0, i1] * fx
        bottom = img[j1, i0] * (1.0 - fx) + img[j1, i1] * fx
        return top * (1.0 - fy) + bottom * fy

    def _wrap(self, i: np.ndarray, n: int) -> np.ndarray:
        if self.wrap == "repeat":
            return np.mod(i, n)
        if self.wrap == "clamp":
            return np.clip(i, 0, n - 1)
        p = np.mod(i, 2 * n)
        return np.where(p < n, p, 2 * n - 1 - p)

    def __repr__(self) -> str:
        h, w = self.image.shape[:2]
        return f"Texture(name={self.name!r}, {w} x {h} pixels, {self.wrap}, {self.filter})"


def read_image(path, *, raw: bool = False) -> np.ndarray:
    """(H, W, 3) float64 linear RGB of an image file (OpenImageIO): floating-point files
    (EXR, HDR) as stored, 8- and 16-bit ones (PNG, JPEG, BMP) decoded from sRGB unless ``raw``,
    as Mitsuba's bitmaps are; one channel is grey, a fourth (alpha) is dropped."""
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(str(path))
    if buf.has_error:
        raise InputError(f"cannot read the image {str(path)!r}: {buf.geterror()}; give an EXR, "
                         "HDR, PNG or JPEG file")
    spec = buf.spec()
    pixels = np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float64)
    pixels = pixels.reshape(spec.height, spec.width, spec.nchannels)
    if spec.nchannels in (1, 2):  # grey, or grey and alpha
        pixels = np.repeat(pixels[..., :1], 3, axis=2)
    elif spec.nchannels in (3, 4):
        pixels = pixels[..., :3]
    else:
        raise InputError(f"the image {str(path)!r} has {spec.nchannels} channels; expected "
                         "grey (1), RGB (3) or RGBA (4)")
    if spec.format.basetype in (oiio.UINT8, oiio.UINT16) and not raw:
        pixels = np.where(pixels <= 0.04045, pixels / 12.92, ((pixels + 0.055) / 1.055) ** 2.4)
    return pixels
