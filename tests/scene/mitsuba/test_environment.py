"""Mitsuba's constant emitter (blockhash/scene/mitsuba/environment.py) rendered against the
in-project light tracer, which models it as any environment light (its photons across the
scene's disc): the glass ball of
tests/reference/mitsuba_xml/ball.xml under its point light and a constant environment, whose
light the ball focuses too."""

import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import context_or_skip

from blockhash.scene.loader import load_scene

BALL = Path(__file__).resolve().parents[2] / "reference" / "mitsuba_xml" / "ball.xml"
ENVIRONMENT = '<emitter type="constant"><rgb name="radiance" value="0.3, 0.4, 0.5"/></emitter>'


def ball(tmp_path, environment: bool):
    path = tmp_path / ("env.xml" if environment else "plain.xml")
    text = BALL.read_text()
    path.write_text(text.replace("</scene>", f"  {ENVIRONMENT}\n</scene>") if environment else text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(path)


@pytest.mark.gl
@pytest.mark.slow
def test_the_environments_caustic_is_the_light_tracers(tmp_path):
    """Measured: the caustic's flux per channel within 0.25% of the light tracer's (its own
    noise 0.2%); the environment adds a tenth or more of the point light's alone."""
    context_or_skip("egl")
    import blockhash
    from blockhash.passes.plan import RenderPlan
    from blockhash.reference.lighttrace import light_trace

    scene = ball(tmp_path, True)
    assert [type(light).__name__ for light in scene.lights] == ["PointLight", "EnvironmentLight"]
    image = blockhash.render(scene, photons=100_000, seed=1, plan=RenderPlan(passes=2))
    ref = light_trace(scene, 1_000_000, seed=2)
    seen = ref.visible
    ours = image.caustic.astype(np.float64)[seen].sum(axis=0)
    theirs = ref.radiance[seen].sum(axis=0)
    noise = np.sqrt((ref.stderr[seen] ** 2).sum(axis=0)) / theirs
    assert np.all(np.abs(ours / theirs - 1) < 0.01 + 3 * noise), (ours / theirs, noise)
    alone = light_trace(ball(tmp_path, False), 200_000, seed=2).radiance[seen].sum(axis=0)
    assert np.all(theirs > 1.1 * alone)
