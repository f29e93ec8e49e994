"""Noise-aware limits for image tests: how much two renders differ by the photon seed alone.

A photon map is a Monte Carlo sample: two renders of one scene with the same
settings and different photon seeds differ by the estimate's noise (about
1/sqrt(k) per pixel for a k-nearest-photon estimate).  A test limit below that
noise fails whenever anything changes the photons' random numbers; one far above
it lets real errors through.  :func:`seed_tolerances` measures the noise:

1. render the scene with ``seeds`` consecutive photon seeds at a small size;
2. per layer, the per-pixel spread: the standard deviation over the seeds at each
   pixel, summarised as its mean relative to the layer's mean value and its 95th
   percentile;
3. every pair of seeds compared as in ``blockhash compare`` (RMS, relative RMS,
   mean FLIP);
4. a proposed limit per layer and metric: the largest value over the pairs times
   ``margin``, and at least a floor (:data:`FLOORS`) so that a layer the seed does
   not change (direct light) still tolerates float differences between GL drivers.

The limits hold for tests that compare renders of these settings (scene, size,
photons, k, A, method) made with any seeds; a test whose two images share the
photon map can use far tighter ones.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field

import numpy as np

from blockhash.errors import InputError
from blockhash.evaluate.imagediff import compare_layers

#: Smallest proposed limits: float32 rounding and driver differences on a layer the seed does
#: not change (shader vs CPU reference agree to 1e-4 relative RMS, tests/frame/test_render.py), and
#: a FLIP far below the visible (0.01 is about the least a viewer notices when flipping).
FLOORS = {"relative_rms": 1e-4, "flip": 1e-3}
#: Metrics that get a proposed limit.
PROPOSED = ("rms", "relative_rms", "flip")


@dataclass
class ToleranceReport:
    """Pairwise seed-to-seed differences and the limits they suggest."""

    seeds: list
    settings: dict
    margin: float
    pairs: dict = field(default_factory=dict)      # {layer: {metric: [value per pair]}}
    spread: dict = field(default_factory=dict)     # {layer: {"relative_mean": .., "p95": ..}}
    proposed: dict = field(default_factory=dict)   # {metric: {layer: limit}}
    spread_maps: dict = field(default_factory=dict)

    def table(self) -> str:
        lines = [f"seeds {self.seeds}, " + ", ".join(f"{k} {v}" for k, v in self.settings.items())
                 + f"; {len(next(iter(self.pairs.values()))['rms'])} pairs, margin {self.margin}",
                 f"{'layer':<10} {'metric':<13} {'pair mean':>11} {'pair max':>11} {'proposed':>11}"]
        for layer, metrics in self.pairs.items():
            for metric in PROPOSED:
                v = metrics[metric]
                lines.append(f"{layer:<10} {metric:<13} {np.mean(v):>11.4g} {np.max(v):>11.4g} "
                             f"{self.proposed[metric][layer]:>11.4g}")
        lines.append("per-pixel spread over seeds (std): "
                     + "; ".join(f"{layer} mean {s['relative_mean']:.3g} of the layer's mean, "
                                 f"p95 {s['p95']:.4g}" for layer, s in self.spread.items()))
        return "\n".join(lines)

    def options(self) -> str:
        """The proposed limits as ``blockhash compare`` options."""
        flags = {"rms": "--max-rms", "relative_rms": "--max-rel-rms", "flip": "--max-flip"}
        return " ".join(f"{flags[m]} {layer}={_round_up(v)}" for m in ("relative_rms", "flip")
                        for layer, v in self.proposed[m].items())

    def to_json(self) -> dict:
        return {"seeds": self.seeds, "settings": self.settings, "margin": self.margin,
                "pairs": self.pairs, "spread": self.spread, "proposed": self.proposed,
                "options": self.options()}


def _round_up(x: float) -> str:
    """Two significant digits, rounded up, so the printed limit is never below the proposal."""
    if x <= 0 or not np.isfinite(x):
        return f"{x:g}"
    step = 10.0 ** (np.floor(np.log10(x)) - 1)
    return f"{np.ceil(x / step - 1e-9) * step:.2g}"


def seed_tolerances(scene, *, seeds: int = 4, first_seed: int = 0, photons=None, size=(64, 64),
                    k=None, A=None, method: str = "bh", margin: float = 1.5, backend=None,
                    progress=None, spp=None) -> ToleranceReport:
    """Render ``scene`` with ``seeds`` photon seeds and propose limits (module docstring).

    progress : callable(str), optional
        Told after each render.
    spp : int, optional
        Samples per pixel of every render (default: the scene's, else the renderer's).
    """
    from blockhash.passes.pipeline import render_scene

    if seeds < 2:
        raise InputError.about("{seeds}{value}: need at least 2 seeds to measure seed-to-seed "
                               "noise; use 4 or more for a usable maximum", value=seeds)
    if not margin >= 1:
        raise InputError.about("{margin}{value}: the margin multiplies the largest seed-to-seed "
                               "difference and must be >= 1", value=margin)
    renders = []
    seed_list = list(range(first_seed, first_seed + seeds))
    for seed in seed_list:
        t = time.perf_counter()
        r = render_scene(scene, photons=photons, k=k, A=A, method=method, size=size, seed=seed,
                         backend=backend, spp=spp)
        renders.append(r.layers())
        if progress:
            progress(f"seed {seed}: rendered in {time.perf_counter() - t:.1f} s")
    settings = {"size": f"{size[0]}x{size[1]}", "photons": photons or scene.photons.count,
                "k": k or scene.photons.k, "A": A or scene.photons.A, "method": method,
                "spp": r.spp}
    report = ToleranceReport(seeds=seed_list, settings=settings, margin=margin)
    layers = list(renders[0])
    report.pairs = {layer: {m: [] for m in PROPOSED} for layer in layers}
    for i, j in itertools.combinations(range(seeds), 2):
        result = compare_layers(renders[i], renders[j])
        for layer in layers:
            for m in PROPOSED:
                report.pairs[layer][m].append(result.metrics[layer][m])
    for layer in layers:
        stack = np.stack([r[layer] for r in renders]).astype(np.float64)
        std = stack.std(axis=0, ddof=1).max(axis=2)
        mean = float(stack.mean())
        report.spread_maps[layer] = std
        report.spread[layer] = {"relative_mean": float(std.mean() / mean) if mean > 0 else 0.0,
                                "p95": float(np.percentile(std, 95))}
    for m in PROPOSED:
        report.proposed[m] = {}
        for layer in layers:
            floor = FLOORS.get(m, 0.0)
            if m == "rms":
                floor = FLOORS["relative_rms"] * float(np.sqrt(np.mean(renders[0][layer] ** 2)))
            report.proposed[m][layer] = max(max(report.pairs[layer][m]) * margin, floor)
    return report
