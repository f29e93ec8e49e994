"""The top-level API: blockhash.load_scene and blockhash.render (shaped like mitsuba's
load_file / render), and render_scene's old keywords."""

import warnings
from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash import EstimateOptions, InputError, LookupOptions
from blockhash.passes.pipeline import ONE_PASS, render_scene

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

RING = Path(__file__).resolve().parents[2] / "scenes" / "ring.toml"


@pytest.fixture(scope="module")
def ring():
    return blockhash.load_scene(RING).with_size(24, 24)


@pytest.mark.slow
def test_render_gives_the_layers_of_render_scene(ring):
    est = EstimateOptions(filter="none")
    new = blockhash.render(ring, photons=20_000, spp=1, seed=3, estimate=est,
                           lookup=LookupOptions(k=20, A=4), plan=ONE_PASS)
    old = render_scene(ring, photons=20_000, spp=1, seed=3, options=est, k=20, A=4)
    assert new.caustic.shape == (24, 24, 3) and new.caustic.sum() > 0
    np.testing.assert_array_equal(new.caustic, old.caustic)
    np.testing.assert_array_equal(new.direct, old.direct)
    assert {"trace", "index", "caustic", "total"} <= set(new.timings)


def test_render_reuses_traced_photons(ring):
    from blockhash.photons.tracing import trace_caustic_photons

    photons = trace_caustic_photons(ring, 20_000, seed=5)
    a = blockhash.render(ring, photons=photons, spp=1, lookup=LookupOptions(method="cpu", k=20))
    b = render_scene(ring, photon_map=photons, spp=1, method="cpu", k=20)
    np.testing.assert_array_equal(a.caustic, b.caustic)
    # The photons given were used, not the scene's 200,000 traced again.
    assert a.info["photons_stored"] == len(photons.positions)
    assert a.info["photons_emitted"] == photons.emitted


def test_render_takes_at_most_eight_arguments():
    import inspect

    assert len(inspect.signature(blockhash.passes.pipeline.render).parameters) <= 8


@pytest.mark.slow
def test_render_scene_old_keywords_warn_and_still_work(ring):
    with pytest.warns(DeprecationWarning, match=r"options=EstimateOptions"):
        old = render_scene(ring, photons=20_000, spp=1, k=20, filter="none", normal_test=False)
    new = render_scene(ring, photons=20_000, spp=1, k=20,
                       options=EstimateOptions(filter="none", normal_cos=None))
    np.testing.assert_array_equal(old.caustic, new.caustic)
    with pytest.raises(TypeError, match="unexpected keyword"):
        render_scene(ring, sharpness=2)


def test_bad_options_name_the_new_form(ring):
    with pytest.raises(InputError, match="estimate=EstimateOptions"):
        blockhash.render(ring, estimate="unbiased")
    with pytest.raises(InputError, match="lookup=LookupOptions"):
        blockhash.render(ring, lookup={"k": 5})
    with pytest.raises(InputError, match="method='exact' is not known"):
        LookupOptions(method="exact")
    with pytest.raises(InputError, match="k"):
        LookupOptions(k=0)


def test_with_size_changes_only_the_image_size(ring):
    big = ring.with_size(40, 30)
    assert (big.camera.width, big.camera.height) == (40, 30)
    assert np.array_equal(big.camera.eye, ring.camera.eye) and big.objects == ring.objects
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        blockhash.render(big, photons=5_000, spp=1, lookup=LookupOptions(method="cpu", k=10))


def test_render_is_a_plain_function_with_its_real_parameters():
    """help(blockhash.render) and IDEs show the parameters, as mitsuba.render's."""
    import inspect
    import types

    import blockhash

    assert isinstance(blockhash.render, types.FunctionType)
    params = inspect.signature(blockhash.render).parameters
    assert list(params) == ["scene", "photons", "spp", "seed", "estimate", "lookup", "backend",
                            "plan"]
    assert "Render ``scene``" in blockhash.render.__doc__
