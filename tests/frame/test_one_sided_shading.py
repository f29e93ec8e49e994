"""A one-sided receiver seen from its back is black, and lit only from its front
(blockhash.frame.shading), whichever G-buffer found the point: the rasteriser's
(gl_FrontFacing), the ray-cast one, or a camera ray reflected by a mirror."""

import numpy as np
import pytest
import trimesh
from conftest import context_or_skip

from blockhash.frame.direct_light import direct_light
from blockhash.frame.gbuffer import rasterize
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.frame.subpixel import raycast_gbuffer
from blockhash.scene.model import (
    Camera,
    MirrorMaterial,
    PhongMaterial,
    PointLight,
    Scene,
    SceneObject,
)

#: The two G-buffers; the rasteriser's opens a GL context.
SOURCES = [pytest.param("gl", marks=pytest.mark.gl), "raycast"]


def panel(y: float, half: float, facing: float) -> trimesh.Trimesh:
    """A square at height ``y`` whose front face points along ``facing`` (+1 up, -1 down) y."""
    v = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]])
    faces = np.array([[0, 2, 1], [0, 3, 2]]) if facing > 0 else np.array([[0, 1, 2], [0, 2, 3]])
    return trimesh.Trimesh(v, faces, vertex_normals=np.tile([0.0, facing, 0.0], (4, 1)),
                           process=False)


def floor_scene(facing: float, sided: str, *, light_y: float = 1.0) -> Scene:
    """A floor seen from above, its front facing ``facing``, a light at height ``light_y``."""
    floor = SceneObject("floor", panel(0.0, 1.0, facing),
                        PhongMaterial(kd=0.5, ks=0.0, n=0.0, sided=sided))
    camera = Camera(eye=(0.0, 2.0, 0.5), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0),
                    fov_y_deg=50.0, width=20, height=16)
    return Scene(camera=camera, lights=(PointLight((0.3, light_y, 0.2), 5.0),), objects=(floor,))


def gbuffer(scene, source):
    if source == "gl":
        context_or_skip("egl")
        return rasterize(scene.camera, scene.objects, backend="egl")
    return raycast_gbuffer(scene.camera, SceneRays(scene.objects))


def direct(scene, source):
    rays = SceneRays(scene.objects)
    points = shading_points(scene.camera, gbuffer(scene, source), scene.objects, rays,
                            (MirrorMaterial,))
    return points, direct_light(points, scene.objects, scene.lights, rays)


@pytest.mark.parametrize("source", SOURCES)
def test_the_g_buffer_says_which_face_the_camera_sees(source):
    up = gbuffer(floor_scene(1.0, "one"), source)
    down = gbuffer(floor_scene(-1.0, "one"), source)
    seen = up.object >= 0
    assert seen.mean() > 0.5 and np.array_equal(seen, down.object >= 0)
    assert up.front[seen].all() and not down.front[seen].any()


@pytest.mark.parametrize("source", SOURCES)
def test_a_one_sided_floor_seen_from_its_back_is_black(source):
    lit_points, lit = direct(floor_scene(1.0, "one"), source)
    assert (lit_points.material >= 0).mean() > 0.5 and lit.sum() > 0
    _, two = direct(floor_scene(-1.0, "two"), source)
    np.testing.assert_allclose(two, lit, rtol=1e-6)  # two-sided: either face lit alike
    back_points, back = direct(floor_scene(-1.0, "one"), source)
    assert (back_points.material == -1).all() and back.sum() == 0.0


@pytest.mark.parametrize("source", SOURCES)
def test_a_one_sided_floor_is_lit_only_from_its_front(source):
    """Camera and light both under a floor that faces down: lit; the same floor facing up
    (the camera and the light behind it) is black; two-sided, lit."""
    def under(facing, sided):
        s = floor_scene(facing, sided, light_y=-1.0)
        cam = Camera(eye=(0.0, -2.0, 0.5), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0),
                     fov_y_deg=50.0, width=20, height=16)
        return Scene(camera=cam, lights=s.lights, objects=s.objects)

    assert direct(under(-1.0, "one"), source)[1].sum() > 0
    assert direct(under(1.0, "one"), source)[1].sum() == 0.0
    np.testing.assert_allclose(direct(under(1.0, "two"), source)[1],
                               direct(under(-1.0, "one"), source)[1], rtol=1e-6)


def mirror_and_panel(facing: float, sided: str) -> Scene:
    """The camera looks down at a mirror in which it sees the underside of a panel above it,
    lit from below; the panel's front faces ``facing``."""
    mirror = SceneObject("mirror", panel(0.0, 2.0, 1.0), MirrorMaterial(0.9))
    top = SceneObject("panel", panel(2.0, 3.0, facing),
                      PhongMaterial(kd=0.5, ks=0.0, n=0.0, sided=sided))
    camera = Camera(eye=(0.0, 1.0, 0.6), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0),
                    fov_y_deg=40.0, width=16, height=16)
    return Scene(camera=camera, lights=(PointLight((0.2, 1.5, 0.0), 5.0),),
                 objects=(mirror, top))


@pytest.mark.parametrize("source", SOURCES)
def test_a_back_face_seen_in_a_mirror_is_black(source):
    front_points, front = direct(mirror_and_panel(-1.0, "one"), source)
    assert (front_points.material == 1).mean() > 0.5 and front.sum() > 0
    np.testing.assert_allclose(direct(mirror_and_panel(1.0, "two"), source)[1], front, rtol=1e-6)
    back_points, back = direct(mirror_and_panel(1.0, "one"), source)
    assert (back_points.material == -1).all() and back.sum() == 0.0
