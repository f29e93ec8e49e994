"""Rough mirrors and glass against Mitsuba 3's own ``roughconductor`` and ``roughdielectric``
plugins: the compiled microfacet event (:mod:`blockhash.scene.microfacet`) has the BSDF's
expectation (its reflected and transmitted albedo and the mean direction of each, at normal
and grazing incidence, both distributions, from outside and inside the glass), and the
evaluation the camera's shadow rays use (:func:`blockhash.frame.rough_direct.microfacet_bsdf`)
is Mitsuba's, direction pair by direction pair.  Mitsuba is asked in its importance transport
mode, which carries no eta^2 on a refraction, as blockhash's glass does not.

Needs the extra blockhash[mitsuba]; skipped without it, unless BLOCKHASH_REQUIRE_MITSUBA is
set (CI sets it), where it fails instead."""

import numpy as np
import pytest
from conftest import mitsuba_or_skip

from blockhash.frame.rough_direct import microfacet_bsdf
from blockhash.scene.microfacet import rough_scatter
from blockhash.scene.mitsuba.spectra import conductor_preset

N = 200_000
#: Copper's complex index (Mitsuba's preset), for a conductor's Fresnel term at the microfacet.
CU = conductor_preset("Cu")


@pytest.fixture(scope="module")
def mi():
    mitsuba_or_skip()
    from blockhash.reference.mitsuba import load_mitsuba_module

    return load_mitsuba_module()[0]


def _plugin(mi, kind, alpha, distribution, ior):
    spec = {"type": kind, "alpha": alpha, "distribution": distribution}
    if kind == "roughdielectric":
        spec.update(int_ior=ior, ext_ior=1.0)
    else:
        spec.update(eta={"type": "rgb", "value": list(CU[0])},
                    k={"type": "rgb", "value": list(CU[1])})
    return mi.load_dict(spec)


def _table(kind, alpha, distribution):
    row = np.zeros((1, 12))
    row[0, :3] = 1.0
    if kind == "roughconductor":
        row[0, 3:6], row[0, 6:9], row[0, 9] = CU[0], CU[1], 1.0
    row[0, 10], row[0, 11] = alpha, distribution == "ggx"
    return row


def _rows(value, m) -> np.ndarray:
    """A Mitsuba colour array of width ``m`` as (m, 3) float64."""
    arr = np.asarray(value, dtype=np.float64)
    return arr.T if arr.shape == (3, m) else arr.reshape(m, 3)


def _interaction(mi, wi):
    import drjit as dr

    si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
    si.wi = mi.Vector3f(*(wi[:, c].astype(np.float32) for c in range(3)))
    si.n = mi.Normal3f(0.0, 0.0, 1.0)
    si.sh_frame = mi.Frame3f(si.n)
    return si


#: (BSDF, met from outside): a conductor has no inside.
SIDES = [("roughconductor", True), ("roughdielectric", True), ("roughdielectric", False)]


@pytest.mark.parametrize("kind,outer", SIDES)
@pytest.mark.parametrize("distribution,alpha", [("beckmann", 0.1), ("ggx", 0.3)])
@pytest.mark.parametrize("theta", [0.3, 1.2])
def test_a_rough_event_has_the_expectation_of_mitsubas_bsdf(mi, kind, distribution, alpha,
                                                             theta, outer):
    ior = 1.5
    d = np.tile([np.sin(theta), 0.0, -np.cos(theta)], (N, 1))
    n = np.tile([0.0, 0.0, 1.0], (N, 1))
    u = np.random.default_rng(7).random((N, 3))
    dirs, factor, through = rough_scatter(
        d, n, n.copy(), np.full(N, outer), np.zeros(N, dtype=np.int64),
        _table(kind, alpha, distribution), np.array([kind == "roughdielectric"]),
        np.array([ior]), u)
    # Mitsuba's frame: the interaction's wi toward where the ray came from; from inside the
    # glass Mitsuba sees the same surface from its back (wi.z < 0), blockhash its normal flipped
    wi = -d if outer else -d * np.array([1.0, 1.0, -1.0])
    plugin = _plugin(mi, kind, alpha, distribution, ior)
    ctx = mi.BSDFContext(mi.TransportMode.Importance)
    v = np.random.default_rng(8).random((N, 3)).astype(np.float32)
    bs, weight = plugin.sample(ctx, _interaction(mi, wi), mi.Float(v[:, 0]),
                               mi.Point2f(mi.Float(v[:, 1]), mi.Float(v[:, 2])))
    theirs_w = _rows(weight, N)
    wo = np.stack([np.asarray(bs.wo.x), np.asarray(bs.wo.y), np.asarray(bs.wo.z)], axis=1)
    if not outer:
        wo = wo * np.array([1.0, 1.0, -1.0])
    theirs_t = wo[:, 2] < 0.0
    for ours_mask, theirs_mask in ((~through, ~theirs_t), (through, theirs_t)):
        a = factor[ours_mask].sum(axis=0) / N
        b = theirs_w[theirs_mask].sum(axis=0) / N
        np.testing.assert_allclose(a, b, atol=4e-3, rtol=1e-2)
        if b[0] > 0.02:  # the mean direction of what is reflected or transmitted
            ma = (dirs[ours_mask] * factor[ours_mask, :1]).sum(axis=0) / factor[ours_mask, 0].sum()
            mb = (wo[theirs_mask] * theirs_w[theirs_mask, :1]).sum(axis=0) / theirs_w[theirs_mask, 0].sum()
            np.testing.assert_allclose(ma, mb, atol=6e-3)


@pytest.mark.parametrize("kind,outer", SIDES)
@pytest.mark.parametrize("distribution", ["beckmann", "ggx"])
def test_the_shadow_rays_evaluation_is_mitsubas(mi, kind, outer, distribution):
    rng = np.random.default_rng(3)
    m, alpha, ior = 4000, 0.2, 1.5
    v = rng.normal(size=(m, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    light = rng.normal(size=(m, 3))
    light /= np.linalg.norm(light, axis=1, keepdims=True)
    if kind == "roughconductor":
        light[:, 2] = np.abs(light[:, 2])
    n = np.tile([0.0, 0.0, 1.0], (m, 1))
    dielectric = kind == "roughdielectric"
    ours = microfacet_bsdf(v, light, n, np.full(m, outer), np.full(m, alpha),
                           np.full(m, distribution == "ggx"), np.full(m, dielectric),
                           np.full(m, ior), np.ones((m, 3)), np.ones((m, 3)),
                           np.tile(CU[0], (m, 1)), np.tile(CU[1], (m, 1)),
                           np.full(m, not dielectric))
    plugin = _plugin(mi, kind, alpha, distribution, ior)
    ctx = mi.BSDFContext(mi.TransportMode.Importance)
    flip = np.array([1.0, 1.0, 1.0 if outer else -1.0])  # inside: Mitsuba sees the back
    value = plugin.eval(ctx, _interaction(mi, v * flip),
                        mi.Vector3f(*((light * flip)[:, c].astype(np.float32) for c in range(3))))
    theirs = _rows(value, m)
    np.testing.assert_allclose(ours, theirs, rtol=2e-3, atol=1e-4 * max(theirs.max(), 1.0))


@pytest.mark.parametrize("distribution,alpha,eta", [("beckmann", 0.1, 1.49), ("ggx", 0.3, 1.5),
                                                    ("ggx", 0.05, 1.9)])
@pytest.mark.parametrize("nonlinear", [False, True])
def test_a_rough_coat_is_mitsubas_roughplastic(mi, distribution, alpha, eta, nonlinear):
    """The rough coat (:mod:`blockhash.scene.coat`: its tabulated transmittances and F_dr
    under the base, its microfacet reflection above) evaluates as Mitsuba's ``roughplastic``,
    direction pair by direction pair, grazing ones included."""
    from blockhash.scene import coat
    from blockhash.scene.coat_tables import NODES, rough_tables
    from blockhash.scene.microfacet import ALPHA

    rng = np.random.default_rng(5)
    m, base, spec = 4000, np.array([0.7, 0.4, 0.1]), np.array([1.0, 0.8, 0.5])
    v, light = rng.normal(size=(m, 3)), rng.normal(size=(m, 3))
    v[:, 2], light[:, 2] = np.abs(v[:, 2]), np.abs(light[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    light /= np.linalg.norm(light, axis=1, keepdims=True)
    row = np.zeros((1, coat.COAT_TABLE + NODES))
    row[0, coat.COAT], row[0, ALPHA] = eta, alpha
    row[0, coat.COAT_TABLE:] = rough_tables(eta, alpha, distribution == "ggx")[0]
    zero = np.zeros(m, dtype=np.int64)
    kd = coat.coated_albedo(base, eta, nonlinear, alpha, distribution)
    seen = coat.transmittance(v[:, 2], row, zero) * coat.transmittance(light[:, 2], row, zero)
    diffuse = kd / np.pi * (seen * light[:, 2])[:, None]
    glossy = microfacet_bsdf(v, light, np.tile([0.0, 0.0, 1.0], (m, 1)), np.ones(m, dtype=bool),
                             np.full(m, alpha), np.full(m, distribution == "ggx"),
                             np.zeros(m, dtype=bool), np.ones(m), np.ones((m, 3)),
                             np.tile(spec, (m, 1)), np.full((m, 3), eta), np.zeros((m, 3)),
                             np.ones(m, dtype=bool))
    plugin = mi.load_dict({"type": "roughplastic", "alpha": alpha, "distribution": distribution,
                           "int_ior": eta, "nonlinear": nonlinear,
                           "diffuse_reflectance": {"type": "rgb", "value": list(base)},
                           "specular_reflectance": {"type": "rgb", "value": list(spec)}})
    value = plugin.eval(mi.BSDFContext(), _interaction(mi, v),
                        mi.Vector3f(*(light[:, c].astype(np.float32) for c in range(3))))
    theirs = _rows(value, m)
    # Mitsuba's tables come from its own quadrature: within 1% of blockhash's at grazing angles
    np.testing.assert_allclose(diffuse + glossy, theirs, rtol=1e-2, atol=1e-4 * theirs.max())
