"""assert_images_close: passes within the limits, fails with pictures named in the message."""

import re
from pathlib import Path

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.evaluate.images import write_exr
from blockhash.evaluate.testing import assert_images_close


def image(seed=0, shape=(16, 16, 3)):
    return np.random.default_rng(seed).random(shape).astype(np.float32)


def test_close_images_pass_and_return_the_comparison(tmp_path):
    ref = image()
    result = assert_images_close(ref * 1.01, ref, max_rel_rms=0.02, out_dir=tmp_path)
    assert result.metrics["rgb"]["relative_rms"] == pytest.approx(0.01, rel=1e-4)
    assert list(tmp_path.iterdir()) == []        # nothing written when the test passes


@pytest.mark.slow
def test_failure_names_the_layer_the_metric_and_the_pictures_it_wrote(tmp_path):
    ref = {"direct": image(1), "caustic": image(2)}
    actual = {"direct": ref["direct"], "caustic": ref["caustic"] * 1.5}
    with pytest.raises(AssertionError) as exc:
        assert_images_close(actual, ref, max_rel_rms=0.1, out_dir=tmp_path)
    message = str(exc.value)
    assert "layer 'caustic': relative_rms 0.5 > 0.1 (max_rel_rms, 5x the limit)" in message
    assert "layer 'direct'" not in message
    pictures = re.findall(r"(?:heat map|strip \(actual \| reference \| error\)): (\S+)", message)
    assert len(pictures) == 2
    named = [Path(p) for p in pictures]
    assert all(p.is_file() and p.parent == tmp_path for p in named)
    # Named after the running test.
    assert named[0].name == ("test_failure_names_the_layer_the_metric_and_the_pictures_it_wrote"
                             ".heatmap.png")


def test_files_and_arrays_mix_and_bad_input_is_an_input_error(tmp_path):
    write_exr(tmp_path / "ref.exr", {"rgb": image(3)})
    assert_images_close(image(3), tmp_path / "ref.exr", max_rms=1e-6)
    with pytest.raises(InputError, match=r"actual is 8x8 but reference is 16x16"):
        assert_images_close(image(3, (8, 8, 3)), image(3), max_rms=1.0)
    with pytest.raises(InputError, match=r"missing\.exr: no such image file"):
        assert_images_close(image(3), tmp_path / "missing.exr", max_rms=1.0)
    with pytest.raises(InputError, match="needs max_rms, max_rel_rms or max_flip"):
        assert_images_close(image(3), image(3))


def test_without_out_dir_the_pictures_go_to_a_new_temporary_directory(tmp_path, monkeypatch):
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with pytest.raises(AssertionError, match=r"heat map: \S*/blockhash-\S*/pic\.heatmap\.png"):
        assert_images_close(image(4), image(5), max_flip=0.0, name="pic")
    assert len(list(tmp_path.glob("blockhash-*/pic.strip.png"))) == 1
