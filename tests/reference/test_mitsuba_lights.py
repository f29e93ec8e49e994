"""Area and directional lights against Mitsuba 3: the Cornell box (an area light) and the glass
ball in sunlight (a directional light), the caustic against Mitsuba's particle tracer and the
in-project light tracer, the direct layer and its soft shadows against Mitsuba's path tracer.

Needs the extra blockhash[mitsuba]; skipped without it, unless BLOCKHASH_REQUIRE_MITSUBA is
set (CI sets it), where it fails instead.  Images are 64 x 64 with coarse spheres, so that the
whole file runs in well under a minute; tools/light_kinds.py measures the same at 512 x 512."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import mitsuba_or_skip
from scipy.ndimage import binary_erosion, uniform_filter

from blockhash.frame.camera_samples import camera_samples
from blockhash.frame.direct_light import direct_light
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.subpixel import box_filter
from blockhash.reference.lighttrace import light_trace
from blockhash.reference.mitsuba import mitsuba_reference, render_mitsuba, without_specular_lobes
from blockhash.scene.camera import Pinhole
from blockhash.scene.loader import parse_scene
from blockhash.studies.lights import soft_shadow_errors

SCENES = Path(__file__).resolve().parents[2] / "scenes"
SIZE = (64, 64)


@pytest.fixture(scope="module", autouse=True)
def needs_mitsuba():
    mitsuba_or_skip()


def scene_of(name: str):
    text = re.sub(r"(radius = [0-9.]+)\n", r"\1\nsubdivisions = 4\n",
                  (SCENES / f"{name}.toml").read_text())
    return without_specular_lobes(parse_scene(text, path=SCENES / f"{name}.toml")).with_size(*SIZE)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cbox", "sun"])
def test_the_caustic_agrees_with_mitsubas_particle_tracer_and_the_light_tracer(name):
    """Caustic flux within 2% and the noise (the light tracer against Mitsuba's isolation at
    1/1024: cbox within 1% at 64 x 64, tools/mitsuba_agreement.py) and the blurred caustic
    within 0.06."""
    scene = scene_of(name)
    ref = mitsuba_reference(scene, 256, layers=("caustic",))
    lt = light_trace(scene, 1_000_000)
    mask = lt.comparison_mask(1)
    a, b = ref.caustic.astype(np.float64), lt.radiance
    assert b[mask].sum() > 0
    noise = np.sqrt((lt.stderr[mask] ** 2).sum())
    assert abs(a[mask].sum() - b[mask].sum()) < 0.02 * b[mask].sum() + 4 * noise
    A, B = uniform_filter(a, (5, 5, 1)), uniform_filter(b, (5, 5, 1))
    bright = mask & (B.sum(axis=2) > 0.05 * B.sum(axis=2).max())
    rel = np.sqrt(((A - B)[bright] ** 2).mean()) / B[bright].mean()
    assert rel < 0.06, f"blurred relative RMS {rel:.3f} on the caustic's pixels"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cbox", "sun"])
def test_the_rendered_caustic_agrees_with_the_light_tracer(name):
    """blockhash's caustic (4 passes, the photon map) against the in-project light tracer:
    flux within 3% over the pixels both see."""
    from blockhash.passes.pipeline import render
    from blockhash.passes.plan import RenderPlan

    scene = scene_of(name)
    lt = light_trace(scene, 1_000_000)
    image = render(scene, photons=100_000, plan=RenderPlan(passes=4))
    mask = lt.comparison_mask(1)
    ours, ref = image.caustic.astype(np.float64)[mask].sum(), lt.radiance[mask].sum()
    assert ours == pytest.approx(ref, rel=0.03)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["cbox", "sun"])
def test_direct_light_and_soft_shadows_agree_with_mitsubas_path_tracer(name):
    """Mitsuba's path tracer at depth 2 (emitters seen and lit directly) over the receivers
    the camera sees: within 1% in total after 64 passes, and the soft shadows' error at 64
    passes at most 0.2 of that at 4 (measured on cbox: 0.14)."""
    scene = scene_of(name)
    ref, _ = render_mitsuba(scene, "path", 4096, max_depth=2)
    res = soft_shadow_errors(scene, ref.astype(np.float64), SceneRays(scene.objects))
    e4, e64 = res["rel_rms"]
    assert res["ratio"] == pytest.approx(1.0, abs=0.01)
    if name == "cbox":  # sunlight's shadows are hard: nothing to converge but the pixel edges
        assert e64 <= 0.2 * e4, res
    assert e64 < 0.03, res


@pytest.mark.slow
def test_an_area_light_is_seen_at_its_radiance_directly_and_in_the_mirror():
    """The lamp's pixels hold its radiance, as Mitsuba's path tracer gives them (depth 1:
    the emitter seen); the mirror ball shows it and the lit box as Mitsuba's depth 3 does."""
    scene = scene_of("cbox")
    rays = SceneRays(scene.objects)
    points, _ = camera_samples(scene, rays, 4, 0)
    ours = box_filter(points.gather(direct_light(points, scene.objects, scene.lights, rays, 0)), 4)
    seen, _ = render_mitsuba(scene, "path", 1024, max_depth=1)
    lamp = seen.sum(axis=2) > 0.5 * seen.sum(axis=2).max()
    assert lamp.sum() > 4
    assert ours[lamp].sum() == pytest.approx(seen[lamp].sum(), rel=0.03)
    # The mirror ball, the glass ball taken away: Mitsuba at depth 3 holds what blockhash's
    # direct layer holds there (the box lit directly, and the lamp, seen in the mirror)
    scene = replace(scene, objects=tuple(o for o in scene.objects if o.name != "glass_ball"))
    rays = SceneRays(scene.objects)
    points, _ = camera_samples(scene, rays, 4, 0)
    ours = box_filter(points.gather(direct_light(points, scene.objects, scene.lights, rays, 0)), 4)
    in_mirror, _ = render_mitsuba(scene, "path", 1024, max_depth=3)
    pin = Pinhole.of(scene.camera)
    d = pin.pixel_rays()
    _, _, _, obj, _ = rays.first_hit(np.broadcast_to(pin.eye, d.shape).copy(), d)
    ball = [o.name for o in scene.objects].index("mirror_ball")
    mirror = binary_erosion((obj == ball).reshape(SIZE[::-1]), iterations=1)
    assert mirror.sum() > 50
    assert ours[mirror].sum() == pytest.approx(in_mirror[mirror].sum(), rel=0.03)
