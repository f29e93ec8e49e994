"""Caustics seen in mirrors and through glass: a mirror facing away from the camera, a scene
whose caustic is seen only through glass, and the Mitsuba export of both canonical scenes."""

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.frame.scene_rays import SceneRays
from blockhash.passes.pipeline import render_scene
from blockhash.scene.camera import Pinhole
from blockhash.scene.loader import parse_scene

ROOT = Path(__file__).resolve().parents[2]
SCENES = ("mirror.toml", "glass_block.toml")

pytestmark = pytest.mark.gl


def _variant(name, *pairs):
    path = ROOT / "scenes" / name
    text = path.read_text()
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new)
    return parse_scene(text, path=path)


def test_a_mirror_facing_away_from_the_camera_renders():
    scene = _variant("mirror.toml", ("rotate_deg = [135.0, 0.0, 0.0]", "rotate_deg = [-45.0, 0.0, 0.0]"))
    wall = scene.objects[2].mesh
    assert wall.vertex_normals[0] @ (np.asarray(scene.camera.eye) - wall.vertices[0]) < 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = render_scene(scene, photons=20_000, size=(64, 64), spp=1)
    assert np.isfinite(image.combined).all() and image.caustic.sum() > 0


def _pixels_through_glass(scene, size):
    pin = Pinhole.of(scene.camera, size)
    d = pin.pixel_rays()
    hit, _, _, obj, _ = SceneRays(scene.objects).first_hit(np.broadcast_to(pin.eye, d.shape).copy(), d)
    slab = [o.name for o in scene.objects].index("slab")
    return (obj == slab).reshape(size[1], size[0])


def test_a_caustic_seen_only_through_glass_renders_without_a_no_caustic_warning():
    # the camera above the slab, looking straight down through it at the caustic
    scene = _variant("glass_block.toml", ("eye = [0.0, 1.9, 1.6]", "eye = [0.35, 1.9, 0.0]"),
                     ("target = [0.0, 0.0, 0.05]", "target = [0.35, 0.0, 0.0]"),
                     ("up = [0.0, 1.0, 0.0]", "up = [0.0, 0.0, -1.0]"),
                     ("fov_y_deg = 38.0", "fov_y_deg = 12.0"))
    size = (64, 64)
    glass = _pixels_through_glass(scene, size)
    assert glass.all()  # every pixel sees the floor through the slab only
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = render_scene(scene, photons=20_000, size=size, spp=1)
    lum = image.caustic.sum(axis=2)
    assert lum.max() > 10 * np.median(lum[lum > 0]), "no bright caustic seen through the slab"


@pytest.mark.parametrize("name", SCENES)
def test_the_mitsuba_export_keeps_every_object(name, tmp_path):
    from blockhash.scene.mitsuba.exporter import export_mitsuba
    from blockhash.scene.mitsuba.importer import load_mitsuba

    scene = blockhash.load_scene(ROOT / "scenes" / name)
    xml = export_mitsuba(scene, tmp_path, drop_specular=True)
    text = Path(xml).read_text()
    assert len(re.findall(r'<shape type="ply"', text)) == len(scene.objects)
    back = load_mitsuba(xml)
    assert [o.name for o in back.objects] == [o.name for o in scene.objects]
    for a, b in zip(scene.objects, back.objects):
        assert type(a.material) is type(b.material)
        assert len(a.mesh.faces) == len(b.mesh.faces)
        np.testing.assert_allclose(a.mesh.bounds, b.mesh.bounds, atol=1e-6)
