"""Glossy surfaces in whole images against Mitsuba 3 (:mod:`blockhash.studies.published`'s
comparison, flux per channel and blurred relative RMS over the image): rough mirrors and glass
in ``mitsuba_xml/rough.xml`` (a spot and a point light over rough gold and frosted glass: the
highlights that only shadow rays reach, the caustics that the rough surfaces throw) and in
Mitsuba's own material preview of ``roughdielectric`` under the museum's environment map
(``tests/data/mitsuba_published``; its ``roughconductor`` preview, copper, is in the corpus for
``tools/mitsuba_folder.py``: flux within 0.6%, blurred 0.021); plastic (a diffuse base
under a smooth coat) in ``mitsuba_xml/plastic.xml`` (a lamp over a plastic floor that mirrors
a ball of plastic, the coat's caustic on the wall) and ``plastic_direct.xml`` (its direct
light alone, at ``max_depth`` 2: the coat's two transmittances, exactly), and in the published
shiny-plastic preview; rough plastic (the same under a rough coat) in
``mitsuba_xml/roughplastic.xml`` (the lamp and a point light over a rough plastic floor and
ball: the coat's glossy caustic, the point light's highlights) and
``roughplastic_direct.xml`` (its direct light alone: the rough coat's tabulated
transmittances and its highlight).

Needs the extra blockhash[mitsuba]; skipped without it, unless BLOCKHASH_REQUIRE_MITSUBA is
set (CI sets it), where it fails instead."""

from pathlib import Path

import numpy as np
import pytest
from conftest import mitsuba_or_skip

from blockhash.studies.published import compare

HERE = Path(__file__).resolve().parent
PUBLISHED = HERE.parent / "data" / "mitsuba_published" / "docs" / "scenes"
#: The published scenes' limits (the issue's); measured here at these settings (40 pixels, 4
#: passes of 36 samples, Mitsuba at 4,096): rough.xml flux within 0.3%, blurred 0.033; the
#: frosted-glass preview flux within 0.8%, blurred 0.040; plastic.xml within 0.4%, 0.010; the
#: shiny-plastic preview within 0.9%, 0.023; roughplastic.xml within 0.5%, 0.009.
FLUX, BLURRED = 0.02, 0.05
FILES = {"rough": HERE / "mitsuba_xml" / "rough.xml",
         "roughdielectric": PUBLISHED / "bsdf_roughdielectric_rough.xml",
         "plastic": HERE / "mitsuba_xml" / "plastic.xml",
         "plastic, published": PUBLISHED / "bsdf_plastic_shiny.xml",
         "roughplastic": HERE / "mitsuba_xml" / "roughplastic.xml"}
#: Photons a pass, fewer than the default, which costs more than the test needs (a plastic
#: floor is a large target for a lamp's caustic photons, of which its coat reflects a few
#: percent, so a pass emits far more than it stores).
PHOTONS = {"rough": 50_000, "roughdielectric": 50_000, "plastic": 20_000,
           "plastic, published": 20_000, "roughplastic": 20_000}
#: Passes a render; the frosted glass's camera paths (up to eight rough events each) are the
#: noisiest: at 4 passes its blurred error moved between 0.041 and 0.051 with the hit points'
#: last bits (embree's or the device's casts, or the ray offset 2% off), at 8 it measured
#: 0.026 (embree's casts) and 0.036 (the device's).
PASSES = {"roughdielectric": 8}

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module", autouse=True)
def needs_mitsuba():
    mitsuba_or_skip()


@pytest.mark.slow
@pytest.mark.parametrize("name", list(FILES))
def test_rough_surfaces_render_as_mitsuba_renders_them(name):
    row = compare(FILES[name], size=40, spp=4096, passes=PASSES.get(name, 4), samples=36,
                  photons=PHOTONS[name])
    assert row.refused is None, row.refused
    assert np.all(np.abs(row.flux - 1) < FLUX), f"{name}: flux ratio {row.flux}"
    assert row.blurred < BLURRED, f"{name}: blurred relative RMS {row.blurred:.3f}"


#: Measured: plastic_direct.xml flux 1.000, blurred 0.001; roughplastic_direct.xml (Mitsuba's
#: tables from its own quadrature, and its 1,024 samples' noise on the highlight) 0.9985, 0.003.
DIRECT = {"plastic_direct.xml": (0.002, 0.005), "roughplastic_direct.xml": (0.005, 0.01)}


@pytest.mark.parametrize("name", list(DIRECT))
def test_a_plastics_direct_light_is_mitsubas(name):
    row = compare(HERE / "mitsuba_xml" / name, size=48, spp=1024, passes=1)
    flux, blurred = DIRECT[name]
    assert row.refused is None, row.refused
    assert np.all(np.abs(row.flux - 1) < flux), f"flux ratio {row.flux}"
    assert row.blurred < blurred, f"blurred relative RMS {row.blurred:.4f}"
