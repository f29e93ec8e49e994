"""The render in passes (blockhash.passes.renderer): convergence on an analytic plane, one
pass equal to the single render, reproducibility, empty passes, memory, shrinking radii and
the pixel splat."""

import gc
import warnings
import weakref

import numpy as np
import pytest
from plane_scene import SIZE, analytic_caustic, error_against

import blockhash
from blockhash.passes.pipeline import render, render_scene
from blockhash.passes.plan import RenderPlan
from blockhash.passes.renderer import EMPTY_PASSES_WARNING, EmptyPassesWarning, Renderer
from blockhash.passes.schedule import Schedule, shrink


@pytest.mark.gl
def test_passes_converge_on_an_analytic_plane(plane):
    """The error against the analytic caustic falls with passes (radii shrink, samples and
    photons grow), and the flux converges."""
    truth = analytic_caustic(plane)
    r = Renderer(plane)
    errors, flux = {}, {}
    while r.passes < 24:
        r.step()
        if r.passes in (1, 4, 24):
            img = r.image.caustic
            errors[r.passes] = error_against(img, truth)
            flux[r.passes] = float(img[..., 0].sum() / truth.sum())
    assert errors[1] > errors[4] > errors[24], errors
    assert errors[24] < 0.7 * errors[1], errors
    assert abs(flux[24] - 1) < 0.03, flux
    est = r.film.estimated_error()
    assert 0 < est < errors[24] * 1.5  # noise only: at most the measured error and its noise


@pytest.mark.gl
def test_a_one_pass_render_is_the_single_render(plane):
    a = render(plane, spp=4, plan=RenderPlan(passes=1, schedule=Schedule(footprint=0)))
    b = render_scene(plane, spp=4)
    np.testing.assert_array_equal(a.caustic, b.caustic)
    np.testing.assert_array_equal(a.direct, b.direct)
    assert a.passes == 1 and a.spp == 4


@pytest.mark.gl
def test_renders_are_reproducible_per_seed_and_pass_count(plane):
    a = render(plane, plan=RenderPlan(passes=3))
    b = render(plane, plan=RenderPlan(passes=3))
    c = render(plane, seed=9, plan=RenderPlan(passes=3))
    np.testing.assert_array_equal(a.caustic, b.caustic)
    np.testing.assert_array_equal(a.direct, b.direct)
    assert not np.array_equal(a.caustic, c.caustic)
    assert a.passes == 3 and a.spp == 3
    assert a.info["photons_emitted"] == b.info["photons_emitted"]


@pytest.mark.gl
def test_a_pass_that_stores_nothing_counts_and_many_warn(plane, monkeypatch):
    r = Renderer(plane)
    r.step()
    one = r.film.caustic.copy()
    empty = blockhash.photons.tracing.CausticPhotons.empty()
    emitted = r.emitted_per_pass

    def no_photons(count, **kw):
        return type(empty)(empty.positions, empty.directions, empty.normals, empty.powers,
                           count, {})
    monkeypatch.setattr(r.setup.source, "emit", no_photons)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(EMPTY_PASSES_WARNING):
            r.step()
    # the empty passes' emitted photons count: the caustic is diluted, not kept
    np.testing.assert_allclose(r.film.caustic, one * emitted / (emitted * (1 + EMPTY_PASSES_WARNING)),
                               rtol=1e-9)
    assert [w.category for w in caught] == [EmptyPassesWarning]


@pytest.mark.gl
def test_memory_is_one_pass(plane):
    """A pass's photons, index and gather go when the next pass comes: nothing of pass 1 is
    alive after pass 3."""
    r = Renderer(plane)
    r.step()
    first = weakref.ref(r.index)
    r.step()
    r.step()
    gc.collect()
    assert first() is None


@pytest.mark.gl
def test_each_pass_estimates_with_its_shrunk_radii(plane):
    from blockhash.frame.photon_radius import own_radii2

    r = Renderer(plane, schedule=Schedule(footprint=0.0))
    for _ in range(3):
        stats = r.step()
    assert stats.scale == pytest.approx(shrink(2, 2 / 3)) and r.radii.scale == stats.scale
    own = own_radii2(r.index, plane.photons.k)
    np.testing.assert_allclose(r.radii(r.index, plane.photons.k), own * stats.scale, rtol=1e-6)


@pytest.mark.gl
def test_photons_under_a_pixel_footprint_are_splatted_into_their_pixel_keeping_the_flux(plane):
    """At 8 x 8 pixels every caustic photon's disc is under a footprint: the splat takes those
    the camera sees (the gather keeps those outside the image) and the flux is the gather's."""
    small = plane.with_size(8, 8)
    splat = Renderer(small, schedule=Schedule(footprint=1.0))
    gather = Renderer(small, schedule=Schedule(footprint=0.0))
    splat.step()
    gather.step()
    gathered = np.isfinite(splat.radii(splat.index, 50))  # the splatted photons' radii: inf
    assert splat.timings.get("pixel splat", 0) > 0 and gathered.sum() < splat.stored / 2
    a, b = splat.image.caustic.sum(), gather.image.caustic.sum()
    assert a == pytest.approx(b, rel=0.05)
    truth = analytic_caustic(small.with_size(SIZE, SIZE))  # the flux over the same view
    assert a / 3 / 64 == pytest.approx(truth.mean(), rel=0.05)

