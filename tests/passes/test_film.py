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



def test_a_layer_with_nan_or_infinity_is_refused_naming_it_and_the_film_is_unchanged():
    from blockhash.errors import NonFiniteError

    film = Film(4, 5)
    film.add(np.ones((4, 5, 3)), np.ones((4, 5, 3)), 10)
    bad = np.ones((4, 5, 3))
    bad[1, 2, 0] = np.nan
    bad[3, 4, 2] = np.inf
    for layers, name in (((bad, np.ones((4, 5, 3))), "direct"), ((np.ones((4, 5, 3)), bad), "caustic")):
        with pytest.raises(NonFiniteError, match=rf"pass 7 \(here\): the {name} layer has 2 "
                                                 r"non-finite pixels .* of 20, the first at x=2, y=1"):
            film.add(*layers, 10, source="pass 7 (here)")
    with pytest.raises(NonFiniteError, match="the indirect layer has 2"):
        film.add(np.ones((4, 5, 3)), np.ones((4, 5, 3)), 10, bad, 5)
    assert film.passes == 1 and film.indirect is None and (film.caustic == 1).all()
