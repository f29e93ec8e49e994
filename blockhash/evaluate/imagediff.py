"""Per-layer image comparison with pass/fail limits: RMS, relative RMS and NVIDIA FLIP.

What ``blockhash compare``, :func:`blockhash.evaluate.testing.assert_images_close` and
``blockhash tolerance`` share.  B is the reference throughout.

1. Both images become ``{layer: (h, w, 3) float32}`` (an EXR's ``layer.R/G/B``
   channels, or one array, which is the layer ``rgb``); they must have the same
   layers and size, or an :class:`~blockhash.errors.InputError` names the file
   and the mismatch.
2. An optional mask (a layer of A, or a mask image, non-zero in any channel)
   selects the pixels that count.  Against the unbiased references, use the light
   tracer's comparison mask (:meth:`blockhash.reference.lighttrace.LightTraceImage.comparison_mask`):
   pixels seen through a mirror or glass are left out, because the light tracer and
   Mitsuba's ``ptracer`` connect each caustic hit to the pinhole by a straight shadow
   ray, which cannot pass a delta surface (their caustic there is 0 while the render's
   is not); ``tools/mirror_identity.py`` checks those pixels instead.
3. Per layer, over the selected pixels and all three channels:
   ``rms`` = RMS(A - B), ``relative_rms`` = RMS(A - B) / RMS(B) (PSNR would use
   each HDR image's own peak), ``max`` and ``mean`` absolute error, and ``flip``,
   the mean of NVIDIA's FLIP map (``flip-evaluator``, LDR mode, 67 pixels per
   degree) between the layers tone-mapped with one exposure, B's 99.5th
   luminance percentile as white (:func:`blockhash.evaluate.images.tone_map`).
   FLIP is a perceptual difference in [0, 1]: about 0.01 is hard to see when
   flipping between the two images, 0.1 is plain to see.
4. Limits (``rms``, ``relative_rms``, ``flip``) are a single number for every
   layer or ``{layer: number}``; a value passes when ``value <= limit``, so NaN
   fails.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from blockhash.errors import InputError, spell
from blockhash.evaluate.images import read_layers, srgb, white_point, write_exr

#: Metrics that take a limit, and the parameter of :func:`compare_layers` that sets each (a
#: front end spells it as its own option: :meth:`blockhash.errors.BlockHashError.spelled`).
LIMITED = {"rms": "max_rms", "relative_rms": "max_rel_rms", "flip": "max_flip"}
#: Column order of the printed table.
COLUMNS = ("rms", "relative_rms", "max", "flip")
#: Pixels per degree of visual angle for FLIP: the package's default, a 0.7 m wide
#: 4K monitor seen from 0.7 m.
FLIP_PPD = 67.0


def as_layers(image, *, name: str) -> dict[str, np.ndarray]:
    """A path, ``{layer: array}`` or one array -> ``{layer: (h, w, 3) float32}``.

    An (h, w) array or a one-channel layer (a grey image) becomes three equal channels; a bare
    array is the layer ``rgb``.
    """
    if isinstance(image, (str, Path)):
        items = read_layers(image).items()
    else:
        items = image.items() if isinstance(image, dict) else [("rgb", image)]
    out = {}
    for layer, arr in items:
        arr = np.asarray(arr, dtype=np.float32)
        if arr.ndim == 2:
            arr = arr[..., None]
        if arr.ndim == 3 and arr.shape[2] == 1:
            arr = np.repeat(arr, 3, axis=2)
        if arr.ndim != 3 or arr.shape[2] != 3:
            raise InputError(f"{name}: layer {layer!r} has shape {arr.shape}; expected (h, w, 3) "
                             "or (h, w): compare RGB layers")
        out[layer] = arr
    if not out:
        raise InputError(f"{name}: no layer to compare")
    return out


def check_compatible(a: dict, b: dict, *, name_a: str, name_b: str) -> None:
    """Same layer names and the same size in both, or an InputError naming the mismatch."""
    if set(a) != set(b):
        only_a, only_b = sorted(set(a) - set(b)), sorted(set(b) - set(a))
        raise InputError(f"{name_a} and {name_b} have different layers: {name_a} has "
                         f"{sorted(a)}, {name_b} has {sorted(b)} (only in {name_a}: {only_a}, only "
                         f"in {name_b}: {only_b}); compare images rendered with the same layers")
    for layer in a:
        (ha, wa), (hb, wb) = a[layer].shape[:2], b[layer].shape[:2]
        if (ha, wa) != (hb, wb):
            raise InputError(f"{name_a} is {wa}x{ha} but {name_b} is {wb}x{hb} (layer {layer!r}); "
                             "render both at the same size")


def resolve_mask(mask, a: dict, *, shape: tuple[int, int]) -> np.ndarray | None:
    """``None``, a layer name of A, a mask image path or an (h, w[, c]) array -> (h, w) bool."""
    if mask is None:
        return None
    if isinstance(mask, str) and mask in a:
        arr = a[mask]
    elif isinstance(mask, (str, Path)):
        if not Path(mask).is_file():
            raise InputError.about("{mask:bare} {value!r} is neither a layer of the first image "
                                   "({layers}) nor an image file", value=str(mask),
                                   layers=", ".join(sorted(a)))
        arr = np.concatenate(list(read_layers(mask).values()), axis=2)
    else:
        arr = np.asarray(mask)
    arr = arr if arr.ndim == 3 else arr[..., None]
    if arr.shape[:2] != tuple(shape):
        raise InputError.about("{mask:bare} {value}: {w}x{h} but the images are {iw}x{ih}",
                               value=mask if isinstance(mask, (str, Path)) else "array",
                               w=arr.shape[1], h=arr.shape[0], iw=shape[1], ih=shape[0])
    keep = np.any(arr != 0, axis=2)
    if not keep.any():
        raise InputError.about("{mask:bare} selects no pixel (it is zero everywhere); give a mask "
                               "that is non-zero where the images should be compared")
    return keep


def normalise_limits(limits, layers, *, metric: str) -> dict[str, float]:
    """``None``, a number, or ``{layer or '*': number}`` -> ``{layer: limit}`` for ``layers``."""
    option = LIMITED[metric]
    if limits is None:
        return {}
    if not isinstance(limits, dict):
        limits = {"*": limits}
    unknown = sorted(set(limits) - set(layers) - {"*"})
    if unknown:
        raise InputError.about("{%s:bare} names layer(s) {unknown} that the images do not have; "
                               "their layers are {layers}" % option, unknown=unknown,
                               layers=", ".join(sorted(layers)))
    checked = {}
    for key, value in limits.items():
        where = "{%s:bare} is" % option if key == "*" else "{%s:bare} for layer {layer!r} is" % option
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise InputError.about(where + " {value!r}; give a number", layer=key,
                                   value=value) from None
        if not number >= 0:
            raise InputError.about(where + " {value}; give a number >= 0", layer=key, value=number)
        checked[key] = number
    return {layer: checked.get(layer, checked.get("*")) for layer in layers
            if layer in checked or "*" in checked}


def flip_map(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(h, w) FLIP error of A against reference B, both tone-mapped with B's white point."""
    import flip_evaluator

    white = white_point(b)
    ref = np.ascontiguousarray(srgb(b, white=white), dtype=np.float32)
    test = np.ascontiguousarray(srgb(a, white=white), dtype=np.float32)
    error, _, _ = flip_evaluator.evaluate(ref, test, "LDR", inputsRGB=True, applyMagma=False,
                                          computeMeanError=False, parameters={"ppd": FLIP_PPD})
    return np.asarray(error, dtype=np.float32).reshape(a.shape[:2])


def layer_metrics(a: np.ndarray, b: np.ndarray, mask: np.ndarray | None, flip: np.ndarray) -> dict:
    """rms, relative_rms, max, mean and flip of one (h, w, 3) layer over the masked pixels."""
    sel = (slice(None),) if mask is None else (mask,)
    d = (np.asarray(a, np.float64) - np.asarray(b, np.float64))[sel]
    rms = float(np.sqrt(np.mean(d ** 2)))
    ref = float(np.sqrt(np.mean(np.asarray(b, np.float64)[sel] ** 2)))
    rel = rms / ref if ref > 0 else (0.0 if rms == 0 else math.inf)
    return {"rms": rms, "relative_rms": rel, "max": float(np.max(np.abs(d))),
            "mean": float(np.mean(np.abs(d))), "flip": float(np.mean(flip[sel]))}


@dataclass(frozen=True)
class Failure:
    layer: str
    metric: str
    value: float
    limit: float

    def __str__(self) -> str:
        return self.spelled({})

    def spelled(self, names: dict) -> str:
        """The failure with its limit's parameter spelled as ``names`` says (a front end's
        options, :meth:`blockhash.errors.BlockHashError.spelled`), else as the keyword."""
        over = f", {self.value / self.limit:.3g}x the limit" if self.limit > 0 else ""
        return spell("layer {layer!r}: {metric} {value:.6g} > {limit:.6g} ({%s:bare}{over})"
                     % LIMITED[self.metric], {"layer": self.layer, "metric": self.metric,
                                              "value": self.value, "limit": self.limit,
                                              "over": over}, names)


@dataclass
class Comparison:
    """The result of :func:`compare_layers`: metrics per layer, limits and the error maps."""

    a: dict
    b: dict
    metrics: dict
    limits: dict = field(default_factory=dict)
    mask: np.ndarray | None = None
    flip_maps: dict = field(default_factory=dict)
    names: tuple = ("A", "B")

    @property
    def failures(self) -> list[Failure]:
        return [Failure(layer, metric, self.metrics[layer][metric], limit)
                for metric, per_layer in self.limits.items() for layer, limit in per_layer.items()
                if not self.metrics[layer][metric] <= limit]

    @property
    def passed(self) -> bool:
        return not self.failures

    def abs_maps(self) -> dict[str, np.ndarray]:
        """(h, w) largest absolute channel error per pixel of each layer."""
        return {layer: np.max(np.abs(self.a[layer] - self.b[layer]), axis=2) for layer in self.a}

    def table(self) -> str:
        heads = {"rms": "rms", "relative_rms": "relative rms", "max": "max", "flip": "FLIP"}
        lines = [f"{'layer':<10}" + "".join(f" {heads[c]:>13}" for c in COLUMNS)]
        for layer, m in self.metrics.items():
            cells = []
            for c in COLUMNS:
                limit = self.limits.get(c, {}).get(layer)
                mark = "" if limit is None else (" ok" if m[c] <= limit else " !!")
                cells.append(f" {m[c]:>10.4g}{mark:<3}")
            lines.append(f"{layer:<10}" + "".join(cells))
        if self.mask is not None:
            lines.append(f"mask: {int(self.mask.sum()):,} of {self.mask.size:,} pixels")
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {"a": self.names[0], "b": self.names[1], "passed": self.passed,
                "masked_pixels": None if self.mask is None else int(self.mask.sum()),
                "layers": self.metrics, "limits": self.limits,
                "failures": [f.__dict__ for f in self.failures]}


def compare_layers(a, b, *, max_rms=None, max_rel_rms=None, max_flip=None, mask=None,
                   names=("A", "B")) -> Comparison:
    """Compare image ``a`` with the reference ``b`` layer by layer.

    Parameters
    ----------
    a, b : path, ``{layer: (h, w, 3) array}`` or one (h, w, 3) / (h, w) array
    max_rms, max_rel_rms, max_flip : float or ``{layer: float}``, optional
        Limits; a dict may give ``'*'`` for the layers it does not name.
    mask : layer name of ``a``, mask image path or (h, w) array, optional
        Compare only where it is non-zero.
    names : (str, str)
        How errors and reports name the two images (file names by default for paths).
    """
    names = tuple(str(x) if isinstance(x, (str, Path)) else n for x, n in zip((a, b), names))
    la, lb = as_layers(a, name=names[0]), as_layers(b, name=names[1])
    check_compatible(la, lb, name_a=names[0], name_b=names[1])
    shape = next(iter(la.values())).shape[:2]
    keep = resolve_mask(mask, la, shape=shape)
    limits = {metric: normalise_limits(value, la, metric=metric) for metric, value in
              (("rms", max_rms), ("relative_rms", max_rel_rms), ("flip", max_flip))}
    flips = {layer: flip_map(la[layer], lb[layer]) for layer in la}
    metrics = {layer: layer_metrics(la[layer], lb[layer], keep, flips[layer]) for layer in la}
    return Comparison(a=la, b=lb, metrics=metrics, limits={k: v for k, v in limits.items() if v},
                      mask=keep, flip_maps=flips, names=names)


def write_pictures(result: Comparison, *, heatmap=None, strip=None, error: str = "flip",
                   vmax: float | None = None) -> list[Path]:
    """Write the heat map and/or the A | B | error strip of ``result``; return the paths.

    error : {'flip', 'abs'}
        FLIP per pixel (0..1, the same scale for every image), or the largest absolute
        channel error (radiance units).
    vmax : float, optional
        Top of the colour bars; default 1 for FLIP, each layer's 99th percentile for 'abs'.
    """
    from blockhash.evaluate.plots import save_heatmap, save_strip

    if error not in ("flip", "abs"):
        raise InputError(f"error={error!r} is not known; choose 'flip' or 'abs'")
    maps = result.flip_maps if error == "flip" else result.abs_maps()
    if result.mask is not None:
        maps = {k: np.where(result.mask, v, np.nan) for k, v in maps.items()}
    label = "FLIP" if error == "flip" else "|A - B| (max over channels)"
    if vmax is None and error == "flip":
        vmax = 1.0
    written = []
    if heatmap:
        written.append(save_heatmap(heatmap, maps, label=label, vmax=vmax,
                                    title=f"{result.names[0]} vs {result.names[1]}"))
    if strip:
        white = {layer: white_point(img) for layer, img in result.b.items()}
        ldr_a = {k: srgb(v, white=white[k]) for k, v in result.a.items()}
        ldr_b = {k: srgb(v, white=white[k]) for k, v in result.b.items()}
        written.append(save_strip(strip, ldr_a, ldr_b, maps, label=label, vmax=vmax,
                                  names=result.names))
    return written


def compare_images(path_a, path_b, *, diff_path=None) -> dict[str, dict]:
    """Per layer: rms, relative rms (to B), max and mean error, mean FLIP; optional |A-B| EXR.

    The images must have the same layers and size; :func:`compare_layers`
    has the limits, masks and error maps.
    """
    result = compare_layers(path_a, path_b)
    if diff_path:
        write_exr(diff_path, {name: np.abs(result.a[name] - result.b[name]) for name in result.a})
    return result.metrics
