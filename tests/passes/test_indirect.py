"""The indirect layer (light after a diffuse bounce, blockhash.photons.indirect): against the
in-project light tracer on two facing planes and a closed box, against Mitsuba 3's whole image
where installed, left out on request, and traced only where a scene's diffuse surfaces light
one another."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import mitsuba_or_skip

import blockhash
from blockhash.cli import main
from blockhash.passes.plan import RenderPlan
from blockhash.reference.lighttrace import light_trace
from blockhash.scene.loader import load_scene, parse_scene

pytestmark = pytest.mark.gl
SCENES = Path(__file__).resolve().parents[2] / "scenes"

FACING = """
[camera]
eye = [0.0, 0.5, 2.2]
target = [0.0, 0.5, 0.0]
fov_y_deg = 40.0
width = 32
height = 32

[materials.white]
kind = "phong"
kd = 0.7

[[lights]]
kind = "spot"
position = [0.0, 0.5, 0.0]
direction = [0.0, -1.0, 0.0]
power = 40.0
cone_deg = 60.0

# the floor lit by the spot, the ceiling lit only by the floor
[[objects]]
name = "floor"
material = "white"
[objects.shape]
kind = "rectangle"
x = [-1.0, 1.0]
z = [-1.0, 1.0]

[[objects]]
name = "ceiling"
material = "white"
rotate_deg = [180.0, 0.0, 0.0]
translate = [0.0, 1.0, 0.0]
[objects.shape]
kind = "rectangle"
x = [-1.0, 1.0]
z = [-1.0, 1.0]
"""


def box():
    """The Cornell box without its spheres (a closed box but for its front), 32 x 32."""
    scene = load_scene(SCENES / "cbox.toml").with_size(32, 32)
    from dataclasses import replace

    return replace(scene, objects=tuple(o for o in scene.objects if not o.is_specular))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["facing", "box"])
def test_the_indirect_layer_carries_the_light_tracers_flux(name):
    """Over the receivers seen directly, the indirect layer's flux over four seeds is the
    light tracer's within 4 standard errors (the seeds' spread and the tracer's noise)."""
    scene = parse_scene(FACING) if name == "facing" else box()
    lt = light_trace(scene, 1_500_000, layer="indirect")
    mask = lt.comparison_mask(1)
    ref = lt.radiance[mask].sum()
    ref_err = np.sqrt((lt.stderr[mask] ** 2).sum())
    fluxes = []
    for seed in (1, 2, 3, 4):
        image = blockhash.render(scene, photons=20_000, seed=seed, plan=RenderPlan(passes=2))
        assert image.indirect is not None and "indirect" in image.layers()
        fluxes.append(float(image.indirect.astype(np.float64)[mask].sum()))
    mean, err = np.mean(fluxes), np.std(fluxes, ddof=1) / 2.0
    assert ref > 0 and abs(mean - ref) < 4 * np.hypot(err, ref_err) + 0.01 * ref, (fluxes, ref)


def test_the_ceiling_lit_only_by_the_floor_is_lit_and_left_out_on_request(tmp_path):
    scene = parse_scene(FACING)
    image = blockhash.render(scene, photons=5000, plan=RenderPlan(passes=1))
    assert image.indirect is not None and image.indirect.max() > 0
    np.testing.assert_array_equal(image.combined, image.direct + image.caustic + image.indirect)
    assert image.info["indirect"].endswith("stored at second or later diffuse vertices")
    without = blockhash.render(scene, photons=5000, plan=RenderPlan(passes=1, indirect=False))
    assert without.indirect is None and "indirect" not in without.layers()
    np.testing.assert_array_equal(without.direct, image.direct)
    with pytest.raises(blockhash.InputError, match="indirect='no': expected True"):
        RenderPlan(indirect="no")
    text = tmp_path / "facing.toml"
    text.write_text(FACING)
    for flag, layers in (([], {"direct", "caustic", "indirect", "combined"}),
                         (["--no-indirect"], {"direct", "caustic", "combined"})):
        out = tmp_path / f"f{len(flag)}.exr"
        assert main(["render", str(text), "-o", str(out), "--photons", "3000", "--passes", "1",
                     *flag]) == 0
        import OpenImageIO as oiio

        inp = oiio.ImageInput.open(str(out))
        names = {n.split(".")[0] for n in inp.spec().channelnames}
        inp.close()
        assert names == layers


def test_a_light_that_meets_no_diffuse_surface_traces_no_indirect_photon():
    """A spot light turned away from the only surface: no pilot photon meets a diffuse
    surface at all, and the render goes on with no indirect layer (the pilot's first answer,
    before any photon leaves a surface)."""
    from blockhash.passes.task import PassSettings, RenderSetup

    away = FACING.replace("direction = [0.0, -1.0, 0.0]", "direction = [1.0, 0.0, 0.0]")
    away = away.replace("cone_deg = 60.0", "cone_deg = 10.0")
    away = away[:away.index("[[objects]]\nname = \"ceiling\"")]  # the floor alone
    scene = parse_scene(away)
    setup = RenderSetup(scene, PassSettings.of(scene, photons=1000))
    assert setup.indirect is None and setup.indirect_note.startswith("none: no photon of a")


@pytest.mark.parametrize("name", ["ring", "glass", "sun"])
def test_a_scene_whose_diffuse_surfaces_cannot_light_one_another_traces_none(name):
    """One floor (under a mirror ring, a glass ball): no photon leaving it meets another
    diffuse surface, so no indirect photon is traced, the layer is absent and the image is
    the one rendered with the indirect light left out, pixel for pixel."""
    scene = load_scene(SCENES / f"{name}.toml").with_size(24, 24)
    image = blockhash.render(scene, photons=4000, plan=RenderPlan(passes=2))
    assert image.indirect is None and "indirect" not in image.layers()
    assert image.info["indirect"].startswith("none: no photon of a")
    assert not any(k.startswith("indirect") for k in image.timings)
    without = blockhash.render(scene, photons=4000, plan=RenderPlan(passes=2, indirect=False))
    np.testing.assert_array_equal(image.combined, without.combined)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["corner", "cbox"])
def test_the_whole_image_agrees_with_mitsubas_particle_tracer(name):
    """direct + caustic + indirect against Mitsuba's ptracer over the whole scene (no albedo
    dimming) over the receivers seen directly: flux within 2% (without the indirect layer,
    corner has 0.79 of Mitsuba's light and the box 0.84)."""
    mitsuba_or_skip()
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.reference.mitsuba import render_mitsuba, without_specular_lobes
    from blockhash.studies.lights import receivers_seen

    scene = without_specular_lobes(load_scene(SCENES / f"{name}.toml")).with_size(48, 48)
    ref, _ = render_mitsuba(scene, "ptracer", 1024)
    mask = receivers_seen(scene, SceneRays(scene.objects))
    image = blockhash.render(scene, photons=50_000, plan=RenderPlan(passes=8))
    ours = image.combined.astype(np.float64)[mask].sum()
    assert ours == pytest.approx(float(ref[mask].sum()), rel=0.02)
    partial = (image.direct + image.caustic).astype(np.float64)[mask].sum()
    assert partial < 0.9 * ref[mask].sum()
