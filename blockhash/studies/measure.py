"""Error measures of a caustic layer against exact kNN and against the light-traced reference.

All are computed on the pixels where both images mean the same thing (see
:mod:`blockhash.reference.lighttrace`): against exact kNN on every pixel that shades a
receiver (both come from the same photon map and the same shading points, mirror
pixels included); against the reference on its :meth:`comparison_mask` (the receivers
seen directly, one pixel away from mirrors and the background).
"""

from __future__ import annotations

import numpy as np

#: Gaussian blur (pixels) of the "blurred" relative RMS: it removes most per-pixel noise
#: (of both the estimate and the reference) and keeps bias and blur of caustic edges.
BLUR_SIGMA = 2.0


def rel_rms(image, truth, mask) -> float:
    """RMS(image - truth) / RMS(truth) over ``mask`` ((h, w) bool), all channels."""
    a = np.asarray(image, np.float64)[mask]
    b = np.asarray(truth, np.float64)[mask]
    ref = float(np.sqrt(np.mean(b ** 2))) if b.size else 0.0
    return float(np.sqrt(np.mean((a - b) ** 2)) / ref) if ref > 0 else float("nan")


def flux_ratio(image, truth, mask) -> float:
    """sum(image) / sum(truth) over ``mask``: the mean bias (1 = unbiased, < 1 darker)."""
    t = float(np.asarray(truth, np.float64)[mask].sum())
    return float(np.asarray(image, np.float64)[mask].sum() / t) if t > 0 else float("nan")


def box_blur_rel_rms(image, truth, mask, *, bright: float = 0.0, size: int = 5) -> float:
    """The relative RMS of ``image`` against ``truth`` after a ``size`` x ``size`` box blur of
    both (RMS of the difference over the blurred truth's mean), over ``mask`` and, with
    ``bright``, only where the blurred truth's luminance is above that share of its peak (the
    caustic's pixels): how the agreement with Mitsuba is quoted (``tools/mitsuba_agreement.py``)."""
    from scipy.ndimage import uniform_filter

    a = uniform_filter(np.asarray(image, np.float64), (size, size, 1))
    b = uniform_filter(np.asarray(truth, np.float64), (size, size, 1))
    if bright:
        lum = b.sum(axis=2)
        mask = mask & (lum > bright * lum.max())
    return float(np.sqrt(((a - b)[mask] ** 2).mean()) / b[mask].mean())


def masked_blur(image, mask, sigma: float = BLUR_SIGMA) -> np.ndarray:
    """Normalised Gaussian blur of ``image`` inside ``mask`` (pixels outside do not leak in)."""
    from scipy.ndimage import gaussian_filter

    m = mask.astype(np.float64)
    num = np.stack([gaussian_filter(np.asarray(image, np.float64)[..., c] * m, sigma)
                    for c in range(image.shape[-1])], axis=-1)
    den = gaussian_filter(m, sigma)[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 1e-6, num / den, 0.0)


def flip_error(image, truth, mask):
    """Mean HDR-FLIP over ``mask``, or None when ``flip-evaluator`` is not installed."""
    try:
        import flip_evaluator as flip
    except ImportError:
        return None
    scale = float(np.percentile(np.asarray(truth)[mask], 99)) if mask.any() else 1.0
    a = np.where(mask[..., None], image, 0.0).astype(np.float32) / max(scale, 1e-30)
    b = np.where(mask[..., None], truth, 0.0).astype(np.float32) / max(scale, 1e-30)
    err_map, _, _ = flip.evaluate(b, a, "HDR")
    return float(np.asarray(err_map)[mask].mean())


def ldr_flip_error(image, truth, mask):
    """Mean LDR-FLIP over ``mask`` of the two images tone-mapped as the PNG is, with one
    exposure (the truth's white point, :func:`blockhash.evaluate.images.white_point`): what a
    user compares by eye; None when ``flip-evaluator`` is not installed."""
    try:
        import flip_evaluator as flip
    except ImportError:
        return None
    from blockhash.evaluate.images import srgb, white_point

    white = white_point(np.where(mask[..., None], truth, 0.0))
    a = srgb(np.asarray(image, dtype=np.float64), white=white).astype(np.float32)
    b = srgb(np.asarray(truth, dtype=np.float64), white=white).astype(np.float32)
    err_map, _, _ = flip.evaluate(b, a, "LDR")
    return float(np.asarray(err_map)[mask].mean())


def errors_against(image, truth, mask, prefix: str) -> dict:
    """``{prefix}_rel_rms``-style measures of one image against one truth."""
    out = {f"rel_rms_{prefix}": rel_rms(image, truth, mask),
           f"flux_ratio_{prefix}": flux_ratio(image, truth, mask),
           f"rel_rms_{prefix}_blur": rel_rms(masked_blur(image, mask), masked_blur(truth, mask), mask)}
    flip = flip_error(image, truth, mask)
    if flip is not None:
        out[f"flip_{prefix}"] = flip
    return out


def power_law(xs, ys):
    """(exponent, prefactor) of ys = c xs^p, least squares in logs ((None, None) below two
    points)."""
    x, y = np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float))
    if len(x) < 2:
        return None, None
    p, c = np.polyfit(x, y, 1)
    return float(p), float(np.exp(c))
