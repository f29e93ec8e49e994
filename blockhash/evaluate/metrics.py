"""Exact k nearest neighbours and the accuracy metrics of paper section 6.

Per query, comparing an approximate result with the exact one:

false negatives
    photons of the exact k-nearest set missing from the approximate set;
maximum distance dilation
    ratio of the bounding radii, ``d_k(approx) / d_k(exact)`` (inf when the
    approximate search found fewer than k photons);
average distance dilation
    ratio of the mean distances to the k neighbours.

Exact neighbours come from scipy's cKDTree on the same (decoded) positions
the index searches, so that quantization does not count as error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockhash.index.lookups.exact import exact_knn  # noqa: F401 (the metrics' oracle, re-exported)

#: Percentiles reported by :func:`summarize`.
PERCENTILES = (50, 90, 99)


def false_negatives(approx_indices, exact_indices, n: int) -> np.ndarray:
    """(m,) number of exact neighbours missing from each approximate set.

    Both may hold ``n`` for missing entries (cKDTree convention); padding of the
    exact set (k > N) is not a neighbour and is never counted as missed.
    """
    a = np.asarray(approx_indices, dtype=np.int64)
    e = np.asarray(exact_indices, dtype=np.int64)
    # Sort each row once and test membership row by row with a vectorised searchsorted
    # on offset rows, so 262,144 queries take well under a second.
    offset = (np.arange(len(a), dtype=np.int64) * (n + 1))[:, None]
    flat_a = np.sort((a + offset).ravel())
    found = np.searchsorted(flat_a, (e + offset).ravel())
    found = np.minimum(found, len(flat_a) - 1)
    hit = (flat_a[found] == (e + offset).ravel()).reshape(e.shape) & (e < n)
    return ((e < n).sum(axis=1) - hit.sum(axis=1)).astype(np.int64)


def dilations(approx_distances, exact_distances) -> tuple[np.ndarray, np.ndarray]:
    """(maximum, average) distance dilation per query; inf where approx found < k."""
    a = np.asarray(approx_distances, dtype=np.float64)
    e = np.asarray(exact_distances, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        max_d = a[:, -1] / e[:, -1]
        avg_d = a.mean(axis=1) / e.mean(axis=1)
    # A query sitting on k coincident photons has zero exact radius: dilation 1 if also 0.
    max_d = np.where((a[:, -1] == 0) & (e[:, -1] == 0), 1.0, max_d)
    avg_d = np.where((a.mean(axis=1) == 0) & (e.mean(axis=1) == 0), 1.0, avg_d)
    return max_d, avg_d


#: A query is *far* from the photons when its exact k-th neighbour lies within this factor
#: of its nearest one's distance: it is farther from the photons than its neighbourhood is
#: wide, and which k of them are nearest turns on distances that agree to a few per cent
#: (a shading point in a shadow, or on a surface no caustic reaches).
FAR_RATIO = 1.2


def far_queries(exact_distances, ratio: float = FAR_RATIO) -> np.ndarray:
    """(m,) bool: queries whose exact k-th neighbour lies within ``ratio`` times the nearest
    one's distance (``exact_distances`` (m, k), ascending)."""
    d = np.asarray(exact_distances, dtype=np.float64)
    return d[:, -1] < ratio * d[:, 0]


@dataclass(frozen=True)
class Accuracy:
    """Summary of approximate-vs-exact results over a query set."""

    k: int
    queries: int
    false_negatives: dict
    max_dilation: dict
    avg_dilation: dict

    @property
    def fn_fraction(self) -> float:
        """Mean false negatives as a fraction of k."""
        return self.false_negatives["mean"] / self.k

    def __repr__(self) -> str:
        return (f"Accuracy(k={self.k}, queries={self.queries:,}, "
                f"false_negatives={self.fn_fraction:.1%} of k, "
                f"max_dilation mean={self.max_dilation['mean']:.4f}, "
                f"avg_dilation mean={self.avg_dilation['mean']:.4f})")


def summarize(values) -> dict:
    """Mean, percentiles and max of finite values, with the count of infinite ones."""
    v = np.asarray(values, dtype=np.float64)
    fin = v[np.isfinite(v)]
    out = {"mean": float(fin.mean()) if fin.size else float("nan")}
    for p in PERCENTILES:
        out[f"p{p}"] = float(np.percentile(fin, p)) if fin.size else float("nan")
    out["max"] = float(fin.max()) if fin.size else float("nan")
    out["infinite"] = int(v.size - fin.size)
    return out


def accuracy(approx, exact, n: int) -> Accuracy:
    """Compare ``(distances, indices)`` pairs from an approximate and the exact search."""
    ad, ai = approx
    ed, ei = exact
    fn = false_negatives(ai, ei, n)
    max_d, avg_d = dilations(ad, ed)
    return Accuracy(k=ei.shape[1], queries=len(ei), false_negatives=summarize(fn),
                    max_dilation=summarize(max_d), avg_dilation=summarize(avg_d))
