"""Write a trade study: ``tradeoff.json``, images, plots (matplotlib, Agg) and ``report.md``.

Figures, each drawn from ``tradeoff.json`` of the same directory:

* ``accuracy_vs_A.png``: false negatives, distance dilations, caustic relative RMS
  against exact kNN and time ratio against exact kNN, per A (paper Figs. 12 and 14),
  at the largest N with the base k, one line per preset;
* ``pareto.png``: error against the reference (blurred relative RMS) against the
  caustic pass time for every setting, the Pareto front, and the exact-kNN points;
* ``error_vs_N.png``: error against the reference per N for each k (variance against blur);
* ``strip.png``: caustic images at A = 1, 2, 4, 8, 16 beside exact kNN and the
  reference (paper Figs. 11 and 13), one exposure for all.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from blockhash.evaluate.images import write_exr
from blockhash.studies.tradeoff.claims import report_markdown

#: The error the report reads: relative RMS after a 2-pixel blur, against the reference
#: (per-pixel noise of the estimate and of the reference removed, bias and blur kept).
ERROR_KEY = "rel_rms_reference_blur"
STRIP_A = (1, 2, 4, 8, 16)



def _save(fig, out, name: str) -> str:
    """Lay out, write ``out/name`` at the reports' resolution, close; returns ``name``."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    return name


def _error_axes(ax, xlabel: str) -> None:
    """Log-log axes of error against the reference, with a legend."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("relative RMS vs reference (2 px blur)")
    ax.legend(fontsize=7)

def _rows(study, method="bh", **match):
    return [r for r in study["rows"] if r["method"] == method
            and all(r.get(k) == v for k, v in match.items())]


def _time(row) -> float:
    """The pass time of a row: the GL draw where measured, else the pass wall time."""
    s = row["seconds"]
    return s.get("gl_draw") or s["caustic_pass"]


def pareto_front(points):
    """Indices of the (time, error) points that no other point beats in both."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def write_study(study: dict, out_dir) -> Path:
    """Write ``tradeoff.json``, the images, the plots and ``report.md``; return the JSON path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    images = study.pop("_images", {})
    path = out / "tradeoff.json"
    path.write_text(json.dumps(study, indent=1, default=float))
    if images:
        layers = {k: np.asarray(v, np.float32) for k, v in images.items() if k != "mask"}
        if "mask" in images:  # the compared pixels, as 1 in every channel
            layers["mask"] = np.repeat(np.asarray(images["mask"], np.float32)[..., None], 3, axis=2)
        write_exr(out / "images.exr", layers)
    plots = make_plots(study, images, out)
    (out / "report.md").write_text(report_markdown(study, plots))
    return path


def rewrite_report(out_dir) -> Path:
    """Redraw the plots and ``report.md`` of a study directory from its JSON and images."""
    from blockhash.evaluate.images import read_layers

    out = Path(out_dir)
    path = out / "tradeoff.json"
    if not path.is_file():
        from blockhash.errors import InputError
        raise InputError.about("{out_dir}{value}: no tradeoff.json there; give a directory "
                               "written by blockhash tradeoff", value=out)
    study = json.loads(path.read_text())
    images = read_layers(out / "images.exr") if (out / "images.exr").is_file() else {}
    if "mask" in images:
        images["mask"] = images["mask"][..., 0] > 0.5
    plots = make_plots(study, images, out)
    (out / "report.md").write_text(report_markdown(study, plots))
    return out / "report.md"


def make_plots(study: dict, images: dict, out: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    plan = study["plan"]
    top, k0 = max(plan["photons"]), plan["k0"]
    exact_t = {r["method"]: r["seconds"]["caustic_pass"] for r in
               _rows(study, "exact-ckdtree", photons=top, k=k0)
               + _rows(study, "exact-kdtree-shader", photons=top, k=k0)}
    # accuracy vs A (paper Figs. 12 and 14)
    fig, ax = plt.subplots(1, 4, figsize=(16, 3.6))
    for preset in plan["presets"]:
        rows = sorted(_rows(study, photons=top, k=k0, preset=preset, variant="default"),
                      key=lambda r: r["A"])
        if len(rows) < 2:
            continue
        A = [r["A"] for r in rows]
        ax[0].plot(A, [100 * r["false_negatives"] for r in rows], "o-", label=preset)
        ax[1].plot(A, [r["max_dilation"] for r in rows], "o-", label=f"{preset} max")
        ax[1].plot(A, [r["avg_dilation"] for r in rows], "s--", label=f"{preset} average")
        ax[2].plot(A, [r["rel_rms_exact"] for r in rows], "o-", label=preset)
        base = exact_t.get("exact-kdtree-shader") or exact_t.get("exact-ckdtree")
        if base:
            ax[3].plot(A, [_time(r) / base for r in rows], "o-", label=preset)
    for a, title in zip(ax, ("false negatives (% of k)", "distance dilation",
                             "caustic relative RMS vs exact kNN",
                             "pass time / exact kNN caustic time\n(" + ("kd-tree shader"
                              if "exact-kdtree-shader" in exact_t else "cKDTree")
                             + " search + numpy estimate)")):
        a.set_xscale("log", base=2)
        a.set_xlabel("A")
        a.set_title(title, fontsize=9)
        a.legend(fontsize=7)
    fig.suptitle(f"{Path(study['scene']).name}: N = {top:,}, k = {k0}", fontsize=10)
    names.append(_save(fig, out, "accuracy_vs_A.png"))

    # Pareto front: error vs reference against time
    bh = _rows(study)
    pts = [(_time(r), r[ERROR_KEY]) for r in bh]
    fig, ax = plt.subplots(figsize=(7, 5))
    sc = ax.scatter([p[0] for p in pts], [p[1] for p in pts], c=[math.log2(r["A"]) for r in bh],
                    s=[10 + 25 * math.log10(r["photons"] / min(plan["photons"]) + 1) for r in bh],
                    cmap="viridis", label="BH settings (colour log2 A, size N)")
    fig.colorbar(sc, ax=ax, label="log2 A")
    front = pareto_front(pts)
    fx = [pts[i] for i in front]
    ax.plot([p[0] for p in fx], [p[1] for p in fx], "r-", lw=1, label="Pareto front")
    for method, marker in (("exact-ckdtree", "k^"), ("exact-kdtree-shader", "ks")):
        ex = _rows(study, method)
        if ex:
            ax.plot([r["seconds"]["caustic_pass"] for r in ex], [r[ERROR_KEY] for r in ex], marker,
                    mfc="none", label=f"{method} (each N, k)")
    _error_axes(ax, "caustic pass seconds")
    names.append(_save(fig, out, "pareto.png"))

    # error vs N for each k
    fig, ax = plt.subplots(figsize=(7, 5))
    for k in sorted({r["k"] for r in bh}):
        rows = sorted(_rows(study, k=k, A=plan["A0"], preset="default", variant="default"),
                      key=lambda r: r["photons"])
        if len(rows) >= 2:
            line, = ax.plot([r["photons"] for r in rows], [r[ERROR_KEY] for r in rows], "o-",
                            label=f"BH A={plan['A0']}, k={k}")
            ex = sorted(_rows(study, "exact-ckdtree", k=k), key=lambda r: r["photons"])
            ax.plot([r["photons"] for r in ex], [r[ERROR_KEY] for r in ex], "--",
                    color=line.get_color(), label=f"exact kNN, k={k}")
    _error_axes(ax, "photons N")
    names.append(_save(fig, out, "error_vs_N.png"))

    # image strip
    keys = [f"A{a}" for a in STRIP_A if f"A{a}" in images] + \
           [k for k in ("exact", "reference") if k in images]
    if keys:
        ref = np.asarray(images.get("reference", images[keys[0]]))
        lum = ref @ np.array([0.2126, 0.7152, 0.0722])
        white = float(np.percentile(lum[lum > 0], 99.5)) if np.any(lum > 0) else 1.0
        fig, ax = plt.subplots(1, len(keys), figsize=(2.4 * len(keys), 2.7))
        for a, key in zip(np.atleast_1d(ax), keys):
            a.imshow(_expose(np.asarray(images[key], np.float64), white))
            a.set_title(key.replace("A", "A = ") if key.startswith("A") else key, fontsize=9)
            a.axis("off")
        names.append(_save(fig, out, "strip.png"))
    return names


def _expose(img, white) -> np.ndarray:
    """(h, w, 3) uint8 sRGB with ``white`` mapped to 1 (the same for every image of a strip)."""
    x = np.clip(img / max(white, 1e-30), 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    return np.round(srgb * 255).astype(np.uint8)
