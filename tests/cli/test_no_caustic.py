"""A scene whose lights reach no caustic path renders from the command line: exit 0, its
direct light, caustic 0, and one warning that says what pass 0 found
(:func:`blockhash.photons.tracing.no_caustic_reason`)."""

import numpy as np
import pytest
from conftest import RING_OBJECT, RING_TEMPLATE, context_or_skip

pytestmark = pytest.mark.gl


def test_the_ring_with_its_light_under_the_floor_renders_dark_with_one_warning(tmp_path, capsys):
    from blockhash.cli import main
    from blockhash.evaluate.images import read_layers
    from blockhash.photons.tracing import PhotonSource, no_caustic_reason
    from blockhash.reference.lighttrace import light_trace
    from blockhash.scene.loader import load_scene

    context_or_skip("egl")
    path = tmp_path / "dark.toml"
    path.write_text(RING_TEMPLATE.format(eye="[0.0, 1.9, 1.6]", target="[0.0, 0.0, 0.05]",
                                         light="[-2.0, -1.0, 0.0]", ring=RING_OBJECT))
    out = tmp_path / "dark.exr"
    assert main(["render", str(path), "--size", "12x12", "--photons", "1000", "--passes", "2",
                 "-o", str(out)]) == 0
    err = capsys.readouterr().err
    scene = load_scene(path).with_size(12, 12)
    found = no_caustic_reason(PhotonSource(scene).until_stored(1000, seed=scene.photons.seed).stats)
    assert "toward the mirrors ['ring']" in found
    assert err.count("rendering direct light only") == 1, err
    assert found in err, err
    layers = read_layers(out)
    assert np.all(layers["caustic"] == 0)
    # the floor hides the light from all the camera sees: dark, as the light tracer (and
    # Mitsuba) give it
    reference = light_trace(scene, 100_000)
    assert reference.radiance.sum() == 0.0 and reference.stats["stored"] == 0
    assert np.all(layers["direct"] == 0) and np.all(layers["combined"] == 0)
