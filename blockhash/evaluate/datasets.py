"""Synthetic photon sets for tests and benchmarks.

Each generator takes ``n`` and a numpy ``Generator`` and returns ``(n, 3)``
float64 positions in metres (y up).  The shape of each distribution (cluster
centres, weights and widths, hot spots) is fixed by ``LAYOUT_SEED``, not drawn
from ``rng``: two calls with different generators sample the *same*
distribution, so a query set drawn with another seed lands where the photons are.  ``caustic_like`` is the distribution the
issue targets use: what a mirror ring puts on a floor (a thin cardioid band
with a bright cusp, a few hot spots, a dim uniform background), nearly all on
the plane y = 0, with a small share on the ring's inner wall.
"""

from __future__ import annotations

import numpy as np

from blockhash.validate import as_int

#: Seed of the fixed geometry of the clustered and caustic-like distributions.
LAYOUT_SEED = 20021


def uniform(n: int, rng: np.random.Generator) -> np.ndarray:
    """Uniform points in the unit cube [0, 1)^3."""
    n = as_int(n, "n", minimum=0)
    return rng.random((n, 3))


def clustered(n: int, rng: np.random.Generator, *, clusters: int = 20, sigma: float = 0.02) -> np.ndarray:
    """Gaussian clusters of random weight and width in the unit cube (3D, no plane)."""
    n = as_int(n, "n", minimum=0)
    layout = np.random.default_rng(LAYOUT_SEED)
    centres = layout.random((clusters, 3))
    weights = layout.random(clusters) + 0.2
    widths = sigma * (0.25 + layout.random(clusters))
    which = rng.choice(clusters, size=n, p=weights / weights.sum())
    return centres[which] + rng.normal(size=(n, 3)) * widths[which, None]


def planar(n: int, rng: np.random.Generator) -> np.ndarray:
    """Uniform points on the square y = 0, x and z in [-1, 1): a fully degenerate axis."""
    n = as_int(n, "n", minimum=0)
    p = rng.random((n, 3)) * 2.0 - 1.0
    p[:, 1] = 0.0
    return p


#: Shares of the caustic-like set: cardioid band, hot spots, floor background, ring wall.
CAUSTIC_SHARES = (0.55, 0.15, 0.27, 0.03)


def caustic_like(n: int, rng: np.random.Generator, *, ring_radius: float = 0.5) -> np.ndarray:
    """A ring caustic on a floor: 97% of photons at y = 0, 3% on the ring wall.

    - 55% on a cardioid band r = a (1 + cos t) (a = ring_radius / 2) of width
      about 4 mm, denser towards the cusp as a real caustic is;
    - 15% in five Gaussian hot spots of 1-3 cm;
    - 27% uniform over the floor disc inside the ring;
    - 3% uniform on the inner wall of the ring (radius ``ring_radius``, 0.3 m high).
    """
    n = as_int(n, "n", minimum=0)
    counts = rng.multinomial(n, CAUSTIC_SHARES)
    parts = []
    # Cardioid band: parameter density peaks at t = 0 (the cusp side lies at t = pi;
    # weight both the bright fold and the cusp as a caustic does).
    a = 0.5 * ring_radius
    t = rng.vonmises(np.pi, 0.6, counts[0])
    r = a * (1.0 + np.cos(t))
    # x spans [-a/4, 2a] before the shift: centre it so the band lies inside the ring.
    band = np.stack([r * np.cos(t) - 0.875 * a, np.zeros_like(t), r * np.sin(t)], axis=1)
    band[:, [0, 2]] += rng.normal(scale=0.002, size=(counts[0], 2))
    parts.append(band)
    # Hot spots.
    layout = np.random.default_rng(LAYOUT_SEED)
    centres = layout.uniform(-0.3, 0.3, size=(5, 2))
    spread = layout.uniform(0.01, 0.03, 5)
    which = rng.integers(0, 5, counts[1])
    spot = centres[which] + rng.normal(size=(counts[1], 2)) * spread[which, None]
    parts.append(np.stack([spot[:, 0], np.zeros(counts[1]), spot[:, 1]], axis=1))
    # Uniform floor disc inside the ring.
    rr = ring_radius * np.sqrt(rng.random(counts[2]))
    tt = rng.random(counts[2]) * 2.0 * np.pi
    parts.append(np.stack([rr * np.cos(tt), np.zeros(counts[2]), rr * np.sin(tt)], axis=1))
    # Inner wall of the ring.
    tt = rng.random(counts[3]) * 2.0 * np.pi
    parts.append(np.stack([ring_radius * np.cos(tt), 0.3 * rng.random(counts[3]),
                           ring_radius * np.sin(tt)], axis=1))
    p = np.concatenate(parts, axis=0)
    return p[rng.permutation(n)]


#: Name -> generator, for parametrised tests and the benchmark's --data option.
DISTRIBUTIONS = {
    "uniform": uniform,
    "clustered": clustered,
    "planar": planar,
    "caustic": caustic_like,
}
