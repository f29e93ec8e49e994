"""The folder of Mitsuba's kept renders (:mod:`blockhash.studies.reference_cache`): a render is
kept under a key of everything that decides it, so a change to the scene file, to a file it
includes or names, or to the render's settings is a new key, never an old image."""

import numpy as np

from blockhash.studies import reference_cache
from blockhash.studies.reference_cache import CACHE_ENV, keep, kept, render_key, scene_files


def _files(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "ball.obj").write_text("v 0 0 0\n")
    (tmp_path / "parts" / "lights.xml").write_text(
        '<scene version="3.0.0"><shape type="obj"><string name="filename" '
        'value="ball.obj"/></shape></scene>')
    scene = tmp_path / "scene.xml"
    scene.write_text('<scene version="3.0.0"><path value="meshes"/>'
                     '<include filename="parts/lights.xml"/></scene>')
    return scene


def test_the_key_follows_every_file_the_scene_names(tmp_path):
    scene = _files(tmp_path)
    assert [f.name for f in scene_files(scene)] == ["scene.xml", "lights.xml", "ball.obj"]
    key = render_key(scene, (48, 32), 64, 0, {"spp": 16}, "3.9.1 llvm_ad_rgb")
    assert key == render_key(scene, (48, 32), 64, 0, {"spp": "16"}, "3.9.1 llvm_ad_rgb")
    changes = [((48, 48), 64, 0, None), ((48, 32), 65, 0, {"spp": 16}),
               ((48, 32), 64, 1, {"spp": 16}), ((48, 32), 64, 0, {"spp": 17})]
    for size, spp, seed, defines in changes:
        assert render_key(scene, size, spp, seed, defines, "3.9.1 llvm_ad_rgb") != key
    assert render_key(scene, (48, 32), 64, 0, {"spp": 16}, "3.9.2 llvm_ad_rgb") != key
    (tmp_path / "meshes" / "ball.obj").write_text("v 0 0 1\n")  # a mesh two files away
    assert render_key(scene, (48, 32), 64, 0, {"spp": 16}, "3.9.1 llvm_ad_rgb") != key


def test_a_kept_render_is_read_back_whole(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "kept"))
    image = np.random.default_rng(1).random((4, 6, 3))
    assert kept("abc") is None
    keep("abc", image, 2.5)
    back, seconds = kept("abc")
    np.testing.assert_array_equal(back, image.astype(np.float32))
    assert seconds == 2.5 and back.dtype == np.float64
    assert [p.name for p in (tmp_path / "kept").iterdir()] == ["abc.npz"]
    monkeypatch.delenv(CACHE_ENV)
    keep("def", image, 1.0)  # no folder named: nothing kept, nothing read
    assert reference_cache.kept("abc") is None
