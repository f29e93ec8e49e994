"""Rough mirrors and glass in whole images against Mitsuba 3 (:mod:`blockhash.studies.
published`'s comparison, flux per channel and blurred relative RMS over the image):
``mitsuba_xml/rough.xml`` (a spot and a point light over rough gold and frosted glass: the
highlights that only shadow rays reach, the caustics that the rough surfaces throw) and
Mitsuba's own material previews of ``roughconductor`` (copper) and ``roughdielectric`` under
the museum's environment map (``tests/data/mitsuba_published``).

Needs the extra blockhash[mitsuba]; skipped without it, unless BLOCKHASH_REQUIRE_MITSUBA is
set (CI sets it), where it fails instead."""

from pathlib import Path

import numpy as np
import pytest
from conftest import mitsuba_or_skip

from blockhash.studies.published import compare

HERE = Path(__file__).resolve().parent
PUBLISHED = HERE.parent / "data" / "mitsuba_published" / "docs" / "scenes"
#: The published scenes' limits (the issue's); measured here at these settings: rough.xml flux
#: 0.99 and blurred 0.04; the previews flux within 0.6% and blurred 0.021 (copper) and
#: 0.034 (frosted glass).
FLUX, BLURRED = 0.02, 0.05
FILES = {"rough": HERE / "mitsuba_xml" / "rough.xml",
         "roughconductor": PUBLISHED / "bsdf_roughconductor_copper.xml",
         "roughdielectric": PUBLISHED / "bsdf_roughdielectric_rough.xml"}

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module", autouse=True)
def needs_mitsuba():
    mitsuba_or_skip()


@pytest.mark.slow
@pytest.mark.parametrize("name", list(FILES))
def test_rough_surfaces_render_as_mitsuba_renders_them(name):
    row = compare(FILES[name], size=48, spp=4096, passes=4, samples=64)
    assert row.refused is None, row.refused
    assert np.all(np.abs(row.flux - 1) < FLUX), f"{name}: flux ratio {row.flux}"
    assert row.blurred < BLURRED, f"{name}: blurred relative RMS {row.blurred:.3f}"
