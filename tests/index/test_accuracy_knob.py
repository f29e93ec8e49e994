"""A is the one accuracy knob: error never rises as A rises, down to near-exact.

Fixed seeds; photon maps placed as a renderer places shading points (half on the lit
surfaces, half anywhere on the map's surfaces: blockhash.evaluate.photon_maps).
"""

import numpy as np
import pytest

from blockhash import BlockHashIndex
from blockhash.evaluate.metrics import dilations, exact_knn, false_negatives
from blockhash.evaluate.photon_maps import MAPS, queries

AS = (1, 2, 4, 8, 16, 32, 64)
K = 20


def knob(name, n=40_000, m=1_500):
    pm = MAPS[name]
    pts = pm.photons(n, np.random.default_rng(0))
    q = queries(pm, m, np.random.default_rng(1))
    fn, dil = [], []
    for A in AS:
        index = BlockHashIndex(pts, k=K, A=A)
        ed, ei = exact_knn(index.positions, q, K)
        d, i = index.query(q)
        fn.append(false_negatives(i, ei, n).mean() / K)
        dil.append(dilations(d, ed)[1].mean())
    return np.array(fn), np.array(dil)


@pytest.fixture(scope="module", params=["caustic", "room", "tilted", "sphere", "uniform"])
def measured(request):
    return request.param, knob(request.param)


@pytest.mark.slow
def test_false_negatives_never_rise_as_A_rises(measured):
    name, (fn, _) = measured
    assert np.all(np.diff(fn) <= 0), f"{name}: mean false negatives per A {np.round(fn, 4)}"


def test_the_knob_spans_rough_to_near_exact(measured):
    name, (fn, dil) = measured
    assert fn[0] > 0.2, f"{name}: A = 1 should be the fast, rough end"
    assert fn[-1] <= 0.02, f"{name}: A = 64 misses {fn[-1]:.2%} of the neighbours"
    assert dil[-1] <= 1.01 and dil[-1] <= dil[3] <= dil[0]
