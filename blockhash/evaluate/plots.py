"""Pictures of image differences: a false-colour error heat map and an A | B | error strip.

matplotlib draws them on its Agg canvas (``Figure`` + ``FigureCanvasAgg``, no
``pyplot`` state and no display), one row or panel per layer, each error panel
with its own colour bar.  Pixels that are NaN in an error map (outside a
comparison mask) are drawn grey.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from blockhash.errors import InputError

#: Perceptually uniform and readable in grey: FLIP's own heat maps use magma too.
CMAP = "magma"
#: Grey for pixels outside the mask.
MASKED = "0.6"
#: Inches per panel side; with DPI, a panel is about 300 pixels whatever the image size.
PANEL = 3.0
DPI = 100


def _figure(rows: int, cols: int):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(PANEL * cols * 1.15, PANEL * rows + 0.4), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(rows, cols, squeeze=False)


def _cmap():
    from matplotlib import colormaps

    return colormaps[CMAP].with_extremes(bad=MASKED)


def _check_maps(errors: dict) -> dict[str, np.ndarray]:
    if not errors:
        raise InputError("no error map to draw; give at least one layer")
    out = {}
    for layer, e in errors.items():
        e = np.asarray(e, dtype=np.float64)
        if e.ndim != 2:
            raise InputError(f"error map of layer {layer!r} has shape {e.shape}; expected (h, w)")
        out[layer] = e
    return out


#: Default top of an error colour bar: this percentile of the map, so that a few outlier
#: pixels do not paint the rest black (larger values get the top colour, and the bar an arrow).
TOP_PERCENTILE = 99.0


def _scale(e: np.ndarray, vmax: float | None) -> float:
    if vmax is not None:
        return vmax
    finite = e[np.isfinite(e)]
    for top in ((np.percentile(finite, TOP_PERCENTILE), finite.max()) if finite.size else ()):
        if top > 0:
            return float(top)
    return 1.0


def _save(fig, path) -> Path:
    path = Path(path)
    if not path.parent.is_dir():
        raise InputError(f"cannot write {path}: directory {path.parent} does not exist")
    fig.savefig(path, dpi=DPI)
    return path


def _error_panel(fig, ax, e, *, label, vmax, title):
    top = _scale(e, vmax)
    im = ax.imshow(np.ma.masked_invalid(e), cmap=_cmap(), vmin=0.0, vmax=top,
                   interpolation="nearest")
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()
    over = bool(np.nanmax(e) > top) if np.isfinite(e).any() else False
    fig.colorbar(im, ax=ax, shrink=0.85, label=label, extend="max" if over else "neither")


def save_heatmap(path, errors: dict, *, label: str, vmax: float | None = None,
                 title: str | None = None) -> Path:
    """One false-colour panel with a colour bar per layer of ``errors`` ({layer: (h, w)}).

    vmax : float, optional
        Top of every colour bar (1 for FLIP); default each layer's 99th percentile.
    """
    errors = _check_maps(errors)
    fig, axes = _figure(1, len(errors))
    for ax, (layer, e) in zip(axes[0], errors.items()):
        mean = np.nanmean(e) if np.isfinite(e).any() else float("nan")
        _error_panel(fig, ax, e, label=label, vmax=vmax, title=f"{layer}: mean {mean:.4g}")
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def save_strip(path, a: dict, b: dict, errors: dict, *, label: str, vmax: float | None = None,
               names=("A", "B")) -> Path:
    """Rows of A | B | error, one row per layer.

    a, b : {layer: (h, w, 3) float sRGB in [0, 1] or uint8}
    errors : {layer: (h, w)}
    """
    errors = _check_maps(errors)
    missing = sorted((set(errors) - set(a)) | (set(errors) - set(b)))
    if missing:
        raise InputError(f"strip: layer(s) {missing} have an error map but no A or B image")
    fig, axes = _figure(len(errors), 3)
    for row, (layer, e) in zip(axes, errors.items()):
        for ax, img, name in ((row[0], a[layer], names[0]), (row[1], b[layer], names[1])):
            img = np.asarray(img)
            if img.shape[:2] != e.shape:
                raise InputError(f"strip: layer {layer!r} of {name} is {img.shape[1]}x{img.shape[0]} "
                                 f"but its error map is {e.shape[1]}x{e.shape[0]}")
            ax.imshow(img if img.dtype == np.uint8 else np.clip(img, 0, 1), interpolation="nearest")
            ax.set_title(f"{layer}: {Path(str(name)).name}", fontsize=9)
            ax.set_axis_off()
        _error_panel(fig, row[2], e, label=label, vmax=vmax, title=f"{layer}: error")
    return _save(fig, path)
