"""The weights of the two ways a rough vertex of a camera ray reaches an area light
(:mod:`blockhash.frame.rough_direct`): the density that :func:`sampling_pdf` gives is the rough
event's own (the directions it draws, counted in cones), and the weight of a light met by the
sampled ray and that of a point drawn on the light add up to one (the power heuristic, so that
nothing is counted twice or lost).  The images against Mitsuba are
``tests/reference/test_mitsuba_mis.py``'s."""

import numpy as np
import pytest

from blockhash.frame.rough_direct import sampling_pdf
from blockhash.frame.surface_lights import light_weight
from blockhash.scene.microfacet import rough_scatter

N = 400_000


def _events(theta, alpha, ggx, dielectric, outer, ior=1.5):
    d = np.tile([np.sin(theta), 0.0, -np.cos(theta)], (N, 1))
    n = np.tile([0.0, 0.0, 1.0], (N, 1))
    table = np.zeros((1, 12))
    table[0, :3], table[0, 10], table[0, 11] = 1.0, alpha, float(ggx)
    u = np.random.default_rng(11).random((N, 3))
    dirs, factor, through = rough_scatter(d, n, n.copy(), np.full(N, outer),
                                          np.zeros(N, dtype=np.int64), table,
                                          np.array([dielectric]), np.array([ior]), u)
    pdf = sampling_pdf(-d, dirs, n, np.full(N, outer), np.full(N, alpha), np.full(N, ggx),
                       np.full(N, dielectric), np.full(N, ior))
    return dirs, factor[:, 0] > 0.0, through, pdf


@pytest.mark.parametrize("ggx,alpha", [(False, 0.1), (True, 0.3)])
@pytest.mark.parametrize("dielectric,outer", [(False, True), (True, True), (True, False)])
@pytest.mark.parametrize("theta", [0.3, 1.0])
def test_the_density_is_the_rough_events_own(ggx, alpha, dielectric, outer, theta):
    # In a cone about the mean direction of what is reflected (and of what passes through),
    # the sum of 1 / pdf over the events that land there, over N, is the cone's solid angle
    dirs, live, through, pdf = _events(theta, alpha, ggx, dielectric, outer)
    tested = 0
    for part in (~through, through) if dielectric else (~through,):
        sel = live & part
        if sel.sum() < 20_000:  # glass seen from inside past its critical angle: no refraction
            continue
        tested += 1
        axis = dirs[sel].mean(axis=0)
        axis /= np.linalg.norm(axis)
        half = 0.5 * alpha + 0.05  # inside the lobe, where 1 / pdf stays bounded
        inside = sel & (dirs @ axis > np.cos(half))
        estimate = np.sum(1.0 / pdf[inside]) / N
        solid = 2.0 * np.pi * (1.0 - np.cos(half))
        assert inside.sum() > 1000
        assert abs(estimate / solid - 1.0) < 0.04, (estimate, solid, inside.sum())
    assert tested
    assert np.all(pdf[live] > 0.0)  # no direction the event draws is left without a density


def test_the_two_weights_of_a_light_add_to_one():
    rng = np.random.default_rng(3)
    m = 1000
    p_bsdf = 10.0 ** rng.uniform(-3, 4, m)  # per steradian
    d2, cos_y, area = rng.uniform(0.1, 20, m), rng.uniform(0.01, 1, m), 0.37
    p_light = d2 / (cos_y * area)  # the light's point, per steradian
    w_light = p_light ** 2 / (p_light ** 2 + p_bsdf ** 2)
    w_sampled = light_weight(p_bsdf / d2, cos_y, area)
    np.testing.assert_allclose(w_light + w_sampled, 1.0, rtol=1e-12)
    # a ray that left no rough vertex (a mirror's, the camera's) keeps all of the light
    assert np.all(light_weight(np.full(3, np.inf), np.array([0.1, 0.5, 1.0]), area) == 1.0)
    assert np.all(np.isfinite(light_weight(np.zeros(2), np.array([0.0, 1.0]), area)))
