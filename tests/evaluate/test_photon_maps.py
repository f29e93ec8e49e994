"""blockhash.evaluate.photon_maps.named: the maps and extremes the accuracy study and the cover
gather's statistics read, by name."""

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.evaluate.photon_maps import EXTREMES, MAPS, named


def test_every_name_gives_its_map_and_the_extremes_move_or_scale_theirs():
    rng = np.random.default_rng(0)
    for name in MAPS:
        assert named(name) is MAPS[name]
    far = named("tilted@1e4").photons(200, np.random.default_rng(1))
    near = MAPS["tilted"].photons(200, np.random.default_rng(1))
    np.testing.assert_allclose(far - near, np.tile([1e4, 0.0, 0.0], (200, 1)))
    small = named("roomx0.001").photons(200, np.random.default_rng(2))
    np.testing.assert_allclose(small, MAPS["room"].photons(200, np.random.default_rng(2)) * 1e-3)
    assert set(EXTREMES) == {"tilted@1e4", "roomx0.001"}
    assert len(named("plane").surfaces(10, rng)) == 10


def test_an_unknown_name_is_refused_naming_the_choices():
    with pytest.raises(InputError, match=r"photon map 'floor' is not known; choose from .*tilted@1e4"):
        named("floor")
