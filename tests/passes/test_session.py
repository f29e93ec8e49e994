"""Frames handed over one state at a time (blockhash.passes.session): each frame the still
render of its state at the same seed, whatever came before it; only what moved built again;
an object that moves updated in the device's acceleration structure and hit where it went."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.errors import InputError
from blockhash.passes.plan import RenderPlan
from blockhash.passes.session import CAMERA, FIRST, LIGHTS, OBJECTS, FrameSession, what_moved
from blockhash.scene.loader import load_scene

pytestmark = pytest.mark.gl
SCENES = Path(__file__).resolve().parents[2] / "scenes"
SIZE = 32
PHOTONS = 4000
PLAN = RenderPlan(passes=2)


def ring():
    return load_scene(SCENES / "ring.toml").with_size(SIZE, SIZE)


def states(scene):
    """The ring's first state, its camera moved, its light moved, its ring moved (tilted and
    lifted), and the first state again."""
    from blockhash.scene.animation import _rigid

    cam = replace(scene.camera, eye=scene.camera.eye + np.array([0.3, 0.1, 0.0]))
    light = replace(scene.lights[0], position=scene.lights[0].position + np.array([0.2, 0.0, 0.1]))
    j = next(i for i, o in enumerate(scene.objects) if o.is_specular)
    objects = list(scene.objects)
    objects[j] = replace(objects[j], mesh=_rigid(objects[j].mesh, {
        "rotate_deg": np.array([20.0, 0.0, 0.0]), "translate": np.array([0.0, 0.05, 0.0])}))
    return [scene, replace(scene, camera=cam), replace(scene, camera=cam, lights=(light,)),
            replace(scene, camera=cam, lights=(light,), objects=tuple(objects)), scene]


def test_each_frame_is_the_still_render_of_its_state():
    scene = ring()
    session = FrameSession(scene, photons=PHOTONS, plan=PLAN)
    for state in states(scene):
        got = session.frame(state)
        want = blockhash.render(state, photons=PHOTONS, plan=PLAN)
        for layer in ("direct", "caustic"):
            np.testing.assert_array_equal(getattr(got, layer), getattr(want, layer), err_msg=layer)
    assert session.moved == [FIRST, CAMERA, LIGHTS, OBJECTS, OBJECTS]
    assert len(session.seconds) == 5 and session.frames_per_second > 0


def test_a_frame_keeps_what_its_state_did_not_move():
    """The camera's frame keeps the setup's photon source and its kept passes; a light's keeps
    the geometry and materials (embree's and the device's scene) and builds the emitter; an
    object's builds embree's scene and carries the device's over, updated."""
    scene = ring()
    first, camera, light, objects, _ = states(scene)
    session = FrameSession(scene, photons=PHOTONS, plan=PLAN)
    session.frame(first)
    s0 = session.last.setup
    assert s0.cache  # the passes' photons, indices and radii kept for the next frames
    session.frame(camera)
    s1 = session.last.setup
    assert s1.source is s0.source and s1.cache is s0.cache
    session.frame(light)
    s2 = session.last.setup
    assert s2.rays is s0.rays and s2.materials is s0.materials and s2.source is not s0.source
    copies = s2.rays.geometry.__dict__.get("device_copies", {})
    session.frame(objects)
    s3 = session.last.setup
    assert s3.rays is not s2.rays
    if copies:  # the photons ran on a Dr.Jit device: its scene carried over
        assert s3.rays.geometry.device_copies == copies
        assert s2.rays.geometry.device_copies == {}


def test_what_moved_compares_values_not_identities():
    scene = ring()
    first, camera, light, objects, again = states(scene)
    assert what_moved(first, again) == CAMERA
    rebuilt = ring()  # the same file read again: equal values, other objects
    assert what_moved(first, rebuilt) == CAMERA
    assert what_moved(first, camera) == CAMERA
    assert what_moved(camera, light) == LIGHTS
    assert what_moved(light, objects) == OBJECTS
    settings = replace(scene, photons=replace(scene.photons, max_bounces=3))
    assert what_moved(first, settings) == OBJECTS


def test_an_object_that_moves_is_updated_in_the_device_scene_and_hit_where_it_went():
    from blockhash.device.choice import resolve
    from blockhash.device.geometry import DeviceGeometry
    from blockhash.scene.raycast import EmbreeGeometry

    try:
        device = resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")
    mi, _ = device.modules()
    scene = ring()
    before = EmbreeGeometry(scene.objects)
    copy = DeviceGeometry.of(before, device)
    assert DeviceGeometry.of(before, device) is copy  # built once per geometry
    mitsuba_scene = copy.scene
    moved = states(scene)[3]
    after = EmbreeGeometry(moved.objects)
    DeviceGeometry.move(before, after)
    assert DeviceGeometry.of(after, device) is copy and copy.scene is mitsuba_scene
    # rays toward the moved ring's triangles' centres, from 0.3 m out along each face's
    # normal: the updated scene meets each face at 0.3 m, as embree's new scene does
    j = next(i for i, o in enumerate(moved.objects) if o.is_specular)
    faces = np.flatnonzero(after.face_object == j)[::7]
    n = after.face_normals[faces]
    o = after.triangles[faces].mean(axis=1) + 0.3 * n
    ray = mi.Ray3f(mi.Point3f(*o.T.astype(np.float32)), mi.Vector3f(*(-n).T.astype(np.float32)))
    t_device = np.asarray(copy.scene.ray_intersect(ray).t)
    hit, face, _, _ = after.intersect(o, -n)
    own = hit & (face == faces)
    assert own.mean() > 0.9
    np.testing.assert_allclose(t_device[own], 0.3, rtol=1e-4)
    old = np.asarray(DeviceGeometry(before, device).scene.ray_intersect(ray).t)
    assert np.mean(np.abs(old[own] - 0.3) > 1e-3) > 0.9  # the ring did move




def test_a_camera_frame_builds_only_the_gather_its_camera_changes(monkeypatch):
    """The ring's camera sees the mirror: a pass gathers every photon for those points and
    the photons the pixel splat left for the rest.  A camera-only frame builds the second
    again (the splat follows the camera) and keeps the first, a photon stage timed apart
    from the estimate ("mirror cover gather")."""
    from blockhash.index.lookups.cover import CoverGather

    builds = []
    original = CoverGather.build.__func__

    def counted(cls, *args, **kwargs):
        builds.append(1)
        return original(cls, *args, **kwargs)

    monkeypatch.setattr(CoverGather, "build", classmethod(counted))
    scene = ring()
    session = FrameSession(scene, photons=PHOTONS, plan=RenderPlan(passes=1))
    session.frame(scene)
    first = len(builds)
    assert first == 2 and session.last.timings["mirror cover gather"] > 0
    session.frame(states(scene)[1])
    assert len(builds) - first == 1
    # the kept gather equals a fresh one: the frame is the still render of its camera
    want = blockhash.render(states(scene)[1], photons=PHOTONS, plan=RenderPlan(passes=1))
    np.testing.assert_array_equal(session.last.image.caustic, want.caustic)


def test_keywords_move_the_last_frames_state():
    """frame(camera=...) and frame(lights=...) change the last frame's state: the same images
    as the whole states handed over."""
    scene = ring()
    first, camera, light, _, _ = states(scene)
    by_state = FrameSession(scene, photons=PHOTONS, plan=PLAN)
    by_keyword = FrameSession(scene, photons=PHOTONS, plan=PLAN)
    for state, keywords in ((camera, {"camera": camera.camera}),
                            (light, {"lights": list(light.lights)})):
        want = by_state.frame(state)
        got = by_keyword.frame(**keywords)
        np.testing.assert_array_equal(got.caustic, want.caustic)
        np.testing.assert_array_equal(got.direct, want.direct)
    assert by_keyword.moved == [FIRST, LIGHTS]  # the first frame builds the setup


def test_a_camera_of_another_size_renders_its_own_film():
    """A state whose camera has another image size (and so another film: a tent filter's
    weights follow the film) keeps the photons and renders the still of that camera."""
    from blockhash.scene.pixel_filter import PixelFilter

    scene = ring()
    scene = replace(scene, camera=replace(scene.camera, filter=PixelFilter("tent")))
    session = FrameSession(scene, photons=PHOTONS, plan=PLAN)
    session.frame()
    wide = scene.with_size(40, 24)
    got = session.frame(camera=wide.camera)
    assert session.moved == [FIRST, CAMERA] and got.caustic.shape == (24, 40, 3)
    want = blockhash.render(wide, photons=PHOTONS, plan=PLAN)
    np.testing.assert_array_equal(got.caustic, want.caustic)
    np.testing.assert_array_equal(got.direct, want.direct)
