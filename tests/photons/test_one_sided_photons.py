"""A one-sided receiver stores no photon on its back face (blockhash.photons.paths), and the
light tracer, which follows the same paths, sees no caustic there."""

from dataclasses import replace

import numpy as np
import pytest
import trimesh

from blockhash.photons.paths import FATE_NAMES
from blockhash.photons.tracing import PhotonSource
from blockhash.reference.lighttrace import light_trace
from blockhash.scene.model import (
    Camera,
    MirrorMaterial,
    PhongMaterial,
    PhotonSettings,
    PointLight,
    Scene,
    SceneObject,
)


def panel(y: float, half: float, facing: float) -> trimesh.Trimesh:
    """A square at height ``y`` whose face normal (counter-clockwise winding) and vertex
    normals point along ``facing`` (+1 up, -1 down) y."""
    v = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]])
    faces = np.array([[0, 2, 1], [0, 3, 2]]) if facing > 0 else np.array([[0, 1, 2], [0, 2, 3]])
    mesh = trimesh.Trimesh(v, faces, vertex_normals=np.tile([0.0, facing, 0.0], (4, 1)),
                           process=False)
    assert np.allclose(mesh.face_normals, [0.0, facing, 0.0])
    return mesh


def mirror_under_a_ceiling(facing: float, sided: str) -> Scene:
    """A point light between a mirror (below, facing up) and a ceiling that the mirror lights
    from below; the ceiling's front faces ``facing``; the camera, below the ceiling, looks
    up at it."""
    mirror = SceneObject("mirror", panel(0.0, 0.4, 1.0), MirrorMaterial(0.9))
    ceiling = SceneObject("ceiling", panel(2.0, 3.0, facing),
                          PhongMaterial(kd=0.5, ks=0.0, n=0.0, sided=sided))
    camera = Camera(eye=(0.0, 0.3, 1.5), target=(0.0, 2.0, 0.0), up=(0.0, 0.0, -1.0),
                    fov_y_deg=60.0, width=24, height=24)
    return Scene(camera=camera, lights=(PointLight((0.2, 1.0, 0.0), 10.0),),
                 objects=(mirror, ceiling), photons=PhotonSettings(count=2000, seed=3))


def test_no_photon_is_stored_on_the_back_face_of_a_one_sided_receiver():
    back = PhotonSource(mirror_under_a_ceiling(1.0, "one")).until_stored(500, max_emitted=20_000)
    assert len(back) == 0 and back.stats["stopped_by"] == "nothing_stored"
    assert back.stats["absorbed"] > 0.9 * back.emitted  # the ceiling's back takes them all
    assert sum(back.stats[f] for f in FATE_NAMES) == back.emitted == 20_000


@pytest.mark.parametrize("facing, sided", [(-1.0, "one"), (1.0, "two")])
def test_the_front_face_and_a_two_sided_receiver_store_the_same_photons(facing, sided):
    """The photons' paths do not depend on the ceiling's faces: the same photons are stored
    on the front of a one-sided ceiling as on either face of a two-sided one (to float32's
    rounding: the device's kernels interpolate the hit in float32, and the faces' winding
    orders the corners)."""
    ref = PhotonSource(mirror_under_a_ceiling(-1.0, "two")).until_stored(500)
    res = PhotonSource(mirror_under_a_ceiling(facing, sided)).until_stored(500)
    assert len(res) == len(ref) == 500 and res.emitted == ref.emitted
    np.testing.assert_allclose(res.positions, ref.positions, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(res.powers, ref.powers)
    np.testing.assert_allclose(res.normals, ref.normals, rtol=0, atol=1e-6)  # toward the photon: down


def test_the_light_tracer_sees_no_caustic_on_a_one_sided_back_face():
    lit = light_trace(mirror_under_a_ceiling(-1.0, "one"), 20_000, seed=2)
    assert lit.radiance.sum() > 0 and lit.visible.any()
    two = light_trace(mirror_under_a_ceiling(1.0, "two"), 20_000, seed=2)
    np.testing.assert_array_equal(two.radiance, lit.radiance)
    back = light_trace(mirror_under_a_ceiling(1.0, "one"), 20_000, seed=2)
    assert back.radiance.sum() == 0.0 and back.stats["stored"] == 0


def test_the_scene_digest_tells_the_faces_apart():
    from blockhash.reference.lighttrace import scene_digest

    one = mirror_under_a_ceiling(-1.0, "one")
    two = replace(one, objects=(one.objects[0], replace(
        one.objects[1], material=replace(one.objects[1].material, sided="two"))))
    assert scene_digest(one) != scene_digest(two)


def test_the_scene_digest_tells_a_crop_and_a_lens_apart():
    """A crop and a thin lens change what a reference holds (the tradeoff study's budget cache
    is keyed by the digest too); a pinhole's digest stays the same."""
    from blockhash.reference.lighttrace import scene_digest

    scene = mirror_under_a_ceiling(-1.0, "one")
    digests = {scene_digest(replace(scene, camera=replace(scene.camera, **kw)))
               for kw in ({}, {"crop": (0.0, 0.0, 0.5, 0.5)}, {"aperture_radius": 0.05},
                          {"aperture_radius": 0.05, "focus_distance": 2.0})}
    assert len(digests) == 4
    assert scene_digest(replace(scene, camera=replace(scene.camera, focus_distance=2.0))) == \
        scene_digest(scene)  # a pinhole's focus distance changes nothing
