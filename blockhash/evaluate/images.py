"""Image files: multi-layer EXR and tone-mapped PNG (OpenImageIO).

EXR channels are named ``layer.R``, ``layer.G``, ``layer.B`` (layers ``direct``,
``caustic``, ``combined``).  Comparison (RMS, relative RMS, max error, FLIP per layer,
with limits and masks) lives in :mod:`blockhash.evaluate.imagediff`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from blockhash.errors import InputError
from blockhash.validate import finite_image

CHANNELS = ("R", "G", "B")
#: The writers refuse NaN and infinity: no file holds them.
WAY_OUT = "nothing was written; an image file holds finite values only (np.nan_to_num first, to write it anyway)"


def write_exr(path, layers: dict[str, np.ndarray], attributes: dict | None = None) -> None:
    """Write ``{name: (h, w, 3) float}`` as one float EXR with channels name.R/G/B, and
    ``attributes`` (``{"blockhash:spp": 4}``) as header metadata."""
    names = list(layers)
    for name in names:
        finite_image(layers[name], name, f"write_exr {path}", WAY_OUT)
    h, w, _ = layers[names[0]].shape
    # Contiguous whatever the inputs' strides: OpenImageIO refuses non-contiguous channels.
    data = np.ascontiguousarray(np.concatenate([np.asarray(layers[n], dtype=np.float32)
                                                for n in names], axis=2))
    spec = oiio.ImageSpec(w, h, data.shape[2], oiio.FLOAT)
    spec.channelnames = tuple(f"{n}.{c}" for n in names for c in CHANNELS)
    spec.attribute("compression", "zip")
    for name, value in (attributes or {}).items():
        spec.attribute(name, value)
    _write(path, spec, data)


def read_attribute(path, name: str, default=None):
    """One header attribute of an image file (``default`` when it has none)."""
    buf = oiio.ImageBuf(str(path))
    if buf.has_error:
        raise InputError(f"{path}: cannot read: {buf.geterror()}")
    value = buf.spec().getattribute(name)
    return default if value is None else value


def white_point(image: np.ndarray, *, percentile: float = 99.5) -> float:
    """The luminance of (h, w, 3) radiance that tone mapping maps to white: its percentile
    over the lit pixels (1.0 for a black image)."""
    lum = image @ np.array([0.2126, 0.7152, 0.0722])
    return float(np.percentile(lum[lum > 0], percentile)) if np.any(lum > 0) else 1.0


def srgb(image: np.ndarray, *, white: float | None = None) -> np.ndarray:
    """(h, w, 3) radiance -> (h, w, 3) float sRGB in [0, 1], ``white`` (default
    :func:`white_point`) mapping to 1; one ``white`` for two images gives them one exposure."""
    white = white_point(image) if white is None else white
    x = np.clip(image / max(white, 1e-30), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def tone_map(image: np.ndarray, *, percentile: float = 99.5) -> np.ndarray:
    """(h, w, 3) radiance -> (h, w, 3) uint8 sRGB: the given luminance percentile maps to white."""
    return np.round(srgb(image, white=white_point(image, percentile=percentile)) * 255).astype(np.uint8)


def write_png(path, image: np.ndarray) -> None:
    """Tone-map (h, w, 3) radiance and write it as an 8-bit sRGB image."""
    finite_image(image, "image", f"write_png {path}", WAY_OUT)
    write_rgb8(path, tone_map(image))


def write_rgb8(path, pixels: np.ndarray) -> None:
    """Write (h, w, 3) uint8 pixels as they are (PNG, or any format OpenImageIO knows)."""
    h, w, _ = pixels.shape
    _write(path, oiio.ImageSpec(w, h, 3, oiio.UINT8), np.ascontiguousarray(pixels, dtype=np.uint8))


def _write(path, spec, data) -> None:
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), spec):
        raise InputError(f"cannot write {path}: {oiio.geterror()}; check the directory and extension")
    ok = out.write_image(data)
    error = out.geterror()
    out.close()
    if not ok:
        raise InputError(f"cannot write {path}: {error}")


def read_layers(path) -> dict[str, np.ndarray]:
    """{layer: (h, w, c) float32} from an EXR written by :func:`write_exr` (c = 3) or any image.

    Channels ``layer.X`` form the layer ``layer``; unprefixed ones (R, G, B of a PNG) the layer
    ``rgb``.  An alpha channel (``A``) is left out of a layer that has other channels.
    """
    if not Path(path).is_file():
        raise InputError(f"{path}: no such image file")
    buf = oiio.ImageBuf(str(path))
    if buf.has_error:
        raise InputError(f"{path}: cannot read: {buf.geterror()}")
    pixels = buf.get_pixels(oiio.FLOAT)
    names = list(buf.spec().channelnames)
    layers: dict[str, list] = {}
    alphas: dict[str, list] = {}
    for i, name in enumerate(names):
        layer, _, chan = name.rpartition(".")
        (alphas if chan == "A" else layers).setdefault(layer or "rgb", []).append(i)
    for layer, idx in alphas.items():
        layers.setdefault(layer, idx)
    return {layer: pixels[..., idx] for layer, idx in layers.items()}
