"""Published Mitsuba 3 scenes (``tests/data/mitsuba_published``, their sources and licence in
its SOURCES.md) rendered by blockhash and by Mitsuba from the same unchanged files
(:mod:`blockhash.studies.published`): each that blockhash reads renders within 2% of Mitsuba's
flux per channel and a blurred relative RMS of at most 0.05 over the whole image; the one it
refuses (polarised plastic) names the element, its file and line.

Needs the extra blockhash[mitsuba]; skipped without it, unless BLOCKHASH_REQUIRE_MITSUBA is
set (CI sets it), where it fails instead."""

from pathlib import Path

import numpy as np
import pytest
from conftest import mitsuba_or_skip

from blockhash.studies.published import compare, load

HERE = Path(__file__).resolve().parents[1] / "data" / "mitsuba_published" / "docs" / "scenes"
#: Limits of the issue (flux within 2%, blurred relative RMS 0.05); measured at 48 pixels,
#: 4 passes of 64 samples, Mitsuba at 4096: flux within 0.4% (the stokes box 0.8%), blurred
#: 0.021 to 0.026 (stokes 0.038; at 16 samples a pass 0.07 to 0.09: the limits see noise).
FLUX, BLURRED = 0.02, 0.05
RENDERED = ["variants_cbox_rgb", "variants_cbox_spectral", "integrator_depth_2",
            "integrator_depth_3", "integrator_depth_inf", "integrator_stokes_cbox",
            "sampler_independent_16spp", "bsdf_twosided_cbox"]
#: Rendered beside Mitsuba here: the others are the same box read otherwise (RGB colours, a
#: stokes wrapper), which the import test holds; tools/mitsuba_folder.py renders them all.
COMPARED = ["variants_cbox_spectral", "integrator_depth_2", "integrator_depth_3",
            "integrator_depth_inf", "sampler_independent_16spp", "bsdf_twosided_cbox",
            "bsdf_diffuse_plain", "bsdf_dielectric_glass", "sensor_thinlens"]
#: Under the museum's environment map (``envmap``): a diffuse material preview, the water one
#: (unbounded depth: light trapped in the water, :data:`blockhash.scene.mitsuba.integrator.
#: UNBOUNDED_SPECULAR`) and the thin lens's depth of field over the same map; measured here
#: flux within 0.8% and blurred 0.019 to 0.030.  The thin lens's file leaves ``$spp`` to the
#: command line.
DEFINES = {"sensor_thinlens": {"spp": "16"}}
#: Tighter on the box at Mitsuba's unbounded depth: its indirect photons stopped after 5
#: surface events made it 1.6% dim; they go on to Russian roulette's end now (measured 0.998).
FLUX_UNBOUNDED = 0.008
#: Fewer photons a pass where the default costs the suite more than it tells: the water at
#: 128 specular events (measured at 50,000: flux within 0.03%, blurred 0.019, as at the
#: default; 17 s against 23 s).
PHOTONS = {"bsdf_dielectric_glass": 50_000}

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module", autouse=True)
def needs_mitsuba():
    mitsuba_or_skip()


@pytest.mark.slow
@pytest.mark.parametrize("name", COMPARED)
def test_a_published_scene_renders_as_mitsuba_renders_it(name):
    row = compare(HERE / f"{name}.xml", size=48, spp=4096, passes=4, samples=64,
                  defines=DEFINES.get(name), photons=PHOTONS.get(name))
    assert row.refused is None
    limit = FLUX_UNBOUNDED if name == "integrator_depth_inf" else FLUX
    assert np.all(np.abs(row.flux - 1) < limit), f"{name}: flux ratio {row.flux}"
    assert row.blurred < BLURRED, f"{name}: blurred relative RMS {row.blurred:.3f}"


def test_what_the_importer_says_of_each_published_file():
    warned = {name: load(HERE / f"{name}.xml")[2] for name in RENDERED}
    assert warned["integrator_stokes_cbox"] and "stokes" in warned["integrator_stokes_cbox"][0]
    assert any("max_depth 2" in w for w in warned["integrator_depth_2"])
    assert not warned["variants_cbox_rgb"] and not warned["variants_cbox_spectral"]
    scene, _, _ = load(HERE / "sampler_independent_16spp.xml")
    plane = [o.name for o in scene.objects if o.name.startswith("Plane-mesh_0/")]
    assert plane == ["Plane-mesh_0/color0", "Plane-mesh_0/color1"]  # the checkerboard's colours
    scene, _, warned = load(HERE / "bsdf_dielectric_glass.xml")
    assert not warned
    env = [li for li in scene.lights if type(li).__name__ == "EnvironmentLight"]
    assert len(env) == 1 and env[0].image.shape == (256, 512, 3)  # museum.exr, times 3
    assert scene.photons.camera_bounces == scene.photons.max_bounces == 128
    scene, refused, warned = load(HERE / "integrator_direct_both.xml")  # Veach's scene
    assert refused is None and scene.photons.direct_only
    assert len(warned) == 1 and "<integrator type=\"direct\">" in warned[0]
    plates = [o.material for o in scene.objects if getattr(o.material, "coat", 0.0)]
    assert [m.alpha for m in plates] == [0.005, 0.02, 0.05, 0.1]  # roughplastic, rough coats
    assert all(m.coat == pytest.approx(2.0 / 1.000277) for m in plates)
    scene, refused, _ = load(HERE / "bsdf_pplastic.xml")
    assert scene is None
    assert "bsdf_pplastic.xml:4: <bsdf type=\"pplastic\">: unsupported BSDF" in refused
