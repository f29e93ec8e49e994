"""How much flux the k-nearest-neighbour estimate adds at a caustic's fold and at a step edge
(``tools/fold_bias.py``): synthetic photons on a plane, the estimate integrated over a window
across the edge and divided by the photons' power inside it.

Photons of total power 1 on the unit square of a plane, uniform in y and, in x,

* ``fold``: x = u^2, density 1 / (2 sqrt(x)) on (0, 1) and nothing at x < 0: the profile
  across a fold line of a caustic (the cardioid's arcs), infinite at the fold;
* ``step``: x uniform on (0, 1): a sharp edge of constant density;
* ``smooth``: x normal (0.3, 0.1): no edge.

The estimate of :mod:`blockhash.frame.estimate` (``unbiased``: the k-1 nearest photons with
the filter's weights, over pi r^2, r the k-th's distance; ``conserving``: each of the k
nearest photons over its own disc, of the radius to its round(k - 2 sqrt(k))-th nearest
other photon, :mod:`blockhash.frame.photon_radius`; exact kNN in 2D) is integrated over
:data:`WINDOW` with stratified jittered points and divided by the power of the photons
inside the window: 1 for an estimate that conserved the photons' power.  The window's
x-edge at 0.5 and its y-edges cross smooth density only, so what is left over is the
estimate's own excess at the edge or fold.
"""

from __future__ import annotations

import numpy as np

#: The window the estimate is integrated over: x0, x1, y0, y1.
WINDOW = (-0.2, 0.5, 0.25, 0.75)

#: The photon distributions across the edge, by name.
SHAPES = ("fold", "step", "smooth")

#: The estimates :func:`flux_ratio` integrates.
ESTIMATES = ("unbiased", "conserving")


def photons(shape: str, n: int, rng) -> np.ndarray:
    """``n`` photon positions (x, y) of the distribution ``shape`` (one of :data:`SHAPES`)."""
    u = rng.random(n)
    x = {"fold": lambda: u ** 2, "step": lambda: u,
         "smooth": lambda: rng.normal(0.3, 0.1, n)}[shape]()
    return np.stack([x, rng.random(n)], axis=1)


def flux_ratio(shape: str, n: int, k: int, filters, *, points: int = 1500, seed: int = 0,
               estimate: str = "unbiased") -> dict:
    """{filter: estimated flux over the window / photon power inside it}: ``n`` photons of
    ``shape``, the k nearest of each of ``points`` x ``points // 2`` jittered points."""
    from scipy.spatial import cKDTree

    from blockhash.frame.estimate import kernel
    from blockhash.frame.photon_radius import neighbours_for

    rng = np.random.default_rng(seed)
    p = photons(shape, n, rng)
    x0, x1, y0, y1 = WINDOW
    ny = points // 2
    gx = x0 + (np.arange(points)[None, :] + rng.random((ny, points))) / points * (x1 - x0)
    gy = y0 + (np.arange(ny)[:, None] + rng.random((ny, points))) / ny * (y1 - y0)
    tree = cKDTree(p)
    d, idx = tree.query(np.stack([gx.ravel(), gy.ravel()], axis=1), k=k, workers=-1)
    inside = np.mean((p[:, 0] > x0) & (p[:, 0] < x1) & (p[:, 1] > y0) & (p[:, 1] < y1))
    if estimate == "conserving":
        j = neighbours_for(k)
        own2 = tree.query(p, k=[j + 1], workers=-1)[0][:, 0][idx] ** 2
    out = {}
    for f in filters:
        if estimate == "conserving":
            t2 = d ** 2 / own2
            radiance = (np.where(t2 < 1, kernel(f, t2), 0.0) / (np.pi * own2)).sum(axis=1) / n
        else:
            r2 = d[:, -1] ** 2
            w = kernel(f, d[:, :-1] ** 2 / r2[:, None]).sum(axis=1)  # the k-th photon left out
            radiance = w / (n * np.pi * r2)
        out[f] = float(radiance.mean() * (x1 - x0) * (y1 - y0) / inside)
    return out
