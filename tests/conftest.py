"""Shared fixtures: seeded generators and small photon sets."""

import numpy as np
import pytest

from blockhash.datasets import DISTRIBUTIONS


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(params=sorted(DISTRIBUTIONS))
def distribution(request):
    """Name of each synthetic photon distribution."""
    return request.param


def photon_set(name: str, n: int, seed: int = 7) -> np.ndarray:
    return DISTRIBUTIONS[name](n, np.random.default_rng(seed))
