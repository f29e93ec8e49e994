"""The film: per-pixel means weighted by the photons each pass emitted, and the spread
between passes (West's weighted incremental variance)."""

import math

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.passes.film import Film


def test_film_means_weigh_passes_by_emitted_photons_and_estimate_their_spread():
    rng = np.random.default_rng(0)
    film = Film(3, 2)
    xs, ws = [], []
    for _ in range(50):
        x = 2.0 + rng.normal(0, 0.5, (3, 2, 3))
        w = int(rng.integers(900, 1100))
        film.add(np.full((3, 2, 3), 0.5), x, w)
        xs.append(x)
        ws.append(w)
    xs, ws = np.array(xs), np.array(ws, float)
    np.testing.assert_allclose(film.caustic, np.tensordot(ws, xs, 1) / ws.sum(), rtol=1e-12)
    np.testing.assert_allclose(film.direct, 0.5)
    # the variance of the mean: about sigma^2 / n
    assert np.mean(film.caustic_variance) == pytest.approx(0.25 / 50, rel=0.15)
    assert film.estimated_error() == pytest.approx(math.sqrt(0.25 / 50) / 2.0, rel=0.15)
    with pytest.raises(InputError, match="does not fit the film"):
        film.add(np.zeros((2, 2, 3)), np.zeros((2, 2, 3)), 1)
    assert Film(2, 2).estimated_error() == math.inf

