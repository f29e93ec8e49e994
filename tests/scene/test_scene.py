"""Scene files: the shipped scenes, the camera matrices and every validation error."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import trimesh

from blockhash.errors import InputError
from blockhash.scene import meshes
from blockhash.scene.loader import load_scene, parse_scene
from blockhash.scene.model import (
    Camera,
    MirrorMaterial,
    PhongMaterial,
    PhotonSettings,
    PointLight,
    Scene,
    SceneObject,
    SpotLight,
)

SCENES = Path(__file__).resolve().parents[2] / "scenes"


@pytest.fixture(scope="module")
def ring_scene():
    return load_scene(SCENES / "ring.toml")


@pytest.fixture(scope="module")
def venus_scene():
    return load_scene(SCENES / "venus.toml")


def _by_name(scene, name):
    (obj,) = [o for o in scene.objects if o.name == name]
    return obj


# --------------------------------------------------------------------------- ring.toml

def test_ring_scene_camera_is_canonical(ring_scene):
    c = ring_scene.camera
    assert c.eye.tolist() == [0.0, 1.9, 1.6]
    assert c.target.tolist() == [0.0, 0.0, 0.05]
    assert c.up.tolist() == [0.0, 1.0, 0.0]
    assert c.fov_y_deg == 38.0
    assert (c.width, c.height) == (512, 512)


def test_ring_scene_floor_is_canonical(ring_scene):
    floor = _by_name(ring_scene, "floor")
    assert floor.mesh.bounds.tolist() == [[-1.5, 0.0, -1.5], [1.5, 0.0, 1.5]]
    assert np.allclose(floor.mesh.vertex_normals, [0.0, 1.0, 0.0])
    assert np.allclose(floor.mesh.face_normals, [0.0, 1.0, 0.0])
    m = floor.material
    assert isinstance(m, PhongMaterial)
    assert m.kd.tolist() == [0.55] * 3 and m.ks.tolist() == [0.25] * 3 and m.n == 20.0


def test_ring_scene_ring_is_canonical(ring_scene):
    ring = _by_name(ring_scene, "ring")
    assert isinstance(ring.material, MirrorMaterial)
    assert ring.material.reflectance.tolist() == [0.95, 0.78, 0.45]
    v, n = ring.mesh.vertices, ring.mesh.vertex_normals
    r = np.hypot(v[:, 0], v[:, 2])
    assert set(np.round(r, 12)) == {0.50, 0.53}
    assert set(v[:, 1]) == {0.0, 0.30}
    assert len(np.unique(np.round(np.arctan2(v[:, 2], v[:, 0]), 9))) == 256
    assert np.allclose(ring.mesh.bounds.mean(axis=0)[[0, 2]], 0.0, atol=1e-12)   # centred
    wall = np.abs(n[:, 1]) < 1e-12
    radial = (n[wall, 0] * v[wall, 0] + n[wall, 2] * v[wall, 2]) / r[wall]
    assert np.allclose(np.abs(radial), 1.0)                 # smooth radial normals
    assert np.allclose(n[~wall], [0.0, 1.0, 0.0])          # flat rim, no bottom on the floor


def test_ring_scene_light_and_photons_are_canonical(ring_scene):
    (light,) = ring_scene.lights
    assert isinstance(light, PointLight)
    assert light.position.tolist() == [-2.0, 1.0, 0.0]
    assert light.power.tolist() == [100.0, 100.0, 100.0]
    assert ring_scene.photons == PhotonSettings(count=200_000, k=50, A=8, seed=1, max_bounces=4)


def test_ring_scene_object_roles(ring_scene):
    assert [o.name for o in ring_scene.objects] == ["floor", "ring"]
    assert [o.name for o in ring_scene.specular_objects] == ["ring"]
    assert [o.name for o in ring_scene.diffuse_objects] == ["floor"]
    assert ring_scene.path == SCENES / "ring.toml"
    assert ring_scene.bounds.tolist() == [[-1.5, 0.0, -1.5], [1.5, 0.3, 1.5]]


def test_summary_and_repr_show_the_numbers(ring_scene):
    text = ring_scene.summary()
    for part in ("eye (0, 1.9, 1.6)", "fov 38 deg, 512 x 512", "point at (-2, 1, 0)",
                 "1,536 triangles", "reflectance (0.95, 0.78, 0.45)", "200,000 stored, k 50, A 8"):
        assert part in text
    assert "no caustics" not in text
    assert "fov_y_deg=38" in repr(ring_scene.camera)
    assert "objects=['floor', 'ring']" in repr(ring_scene)


# --------------------------------------------------------------------------- venus.toml

def test_venus_scene_loads_with_bust_ring_and_lights(venus_scene):
    bust = _by_name(venus_scene, "bust")
    assert len(bust.mesh.faces) >= meshes.MIN_BUST_TRIANGLES
    assert isinstance(bust.material, PhongMaterial)
    assert [o.name for o in venus_scene.specular_objects] == ["ring"]
    assert bust.mesh.bounds[0, 1] == pytest.approx(0.0)        # stands on the floor
    assert len(venus_scene.lights) == 2
    assert venus_scene.photons.k == 50 and venus_scene.photons.A == 8


def test_venus_ring_fits_around_the_neck(venus_scene):
    bust, ring = _by_name(venus_scene, "bust").mesh, _by_name(venus_scene, "ring").mesh
    rv = ring.vertices
    r = np.hypot(rv[:, 0], rv[:, 2])
    inner, lo, hi = r.min(), rv[:, 1].min(), rv[:, 1].max()
    dims = meshes.bust_dimensions()
    assert dims.neck_y[0] <= lo < hi <= dims.neck_y[1]          # at the neck
    bv = bust.vertices
    band = (bv[:, 1] > lo - 0.01) & (bv[:, 1] < hi + 0.01)
    neck = np.hypot(bv[band, 0], bv[band, 2]).max()
    assert neck + 0.03 < inner < 3.0 * neck                     # clear of it, yet around it
    assert not bust.contains(rv).any()                          # no vertex inside the bust


def _trace_key_light(scene, n=20_000, seed=0):
    """Photons from the first light that reach the ring's inner wall first, reflected
    once (flat facets are close enough here): where they hit next."""
    ring = _by_name(scene, "ring").mesh
    others = trimesh.util.concatenate([o.mesh for o in scene.diffuse_objects])
    light = scene.lights[0].position
    rng = np.random.default_rng(seed)
    centre = ring.bounds.mean(axis=0)
    radius = np.linalg.norm(ring.vertices - centre, axis=1).max()
    d = centre + rng.uniform(-radius, radius, (n, 3)) - light
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.tile(light, (n, 1))
    # the ring must be the first thing hit
    loc_r, ray_r, tri_r = ring.ray.intersects_location(o, d, multiple_hits=False)
    loc_o, ray_o, _ = others.ray.intersects_location(o, d, multiple_hits=False)
    t_other = np.full(n, np.inf)
    t_other[ray_o] = np.linalg.norm(loc_o - o[ray_o], axis=1)
    first = np.linalg.norm(loc_r - o[ray_r], axis=1) < t_other[ray_r]
    loc_r, ray_r, tri_r = loc_r[first], ray_r[first], tri_r[first]
    normal = ring.face_normals[tri_r]
    inner = np.einsum("ij,ij->i", normal[:, [0, 2]], (loc_r - centre)[:, [0, 2]]) < 0.0
    loc_r, ray_r, normal = loc_r[inner], ray_r[inner], normal[inner]
    dr = d[ray_r] - 2.0 * np.einsum("ij,ij->i", d[ray_r], normal)[:, None] * normal
    hits, _, _ = others.ray.intersects_location(loc_r + 1e-6 * dr, dr, multiple_hits=False)
    return hits


def test_venus_caustic_falls_on_the_chest(venus_scene):
    """Most light the ring's inner wall reflects lands on the chest below the ring."""
    hits = _trace_key_light(venus_scene)
    assert len(hits) > 300
    lo = _by_name(venus_scene, "ring").mesh.bounds[0, 1]
    chest = (hits[:, 2] > 0.03) & (hits[:, 1] > 0.2) & (hits[:, 1] < lo)
    assert chest.mean() > 0.5
    # ... and in the camera's view
    cam = venus_scene.camera
    clip = np.c_[hits[chest], np.ones(chest.sum())] @ (cam.projection(0.05, 5.0) @ cam.view_matrix()).T
    ndc = clip[:, :3] / clip[:, 3:]
    assert np.all(np.abs(ndc[:, :2]) < 1.0)


# --------------------------------------------------------------------------- camera

def test_camera_maps_target_to_screen_centre_and_eye_to_origin(ring_scene):
    cam = ring_scene.camera
    view = cam.view_matrix()
    assert np.allclose(view @ np.r_[cam.eye, 1.0], [0, 0, 0, 1], atol=1e-12)
    tv = view @ np.r_[cam.target, 1.0]
    dist = np.linalg.norm(cam.target - cam.eye)
    assert np.allclose(tv, [0, 0, -dist, 1], atol=1e-12)          # straight down -z
    assert np.allclose(view[:3, :3] @ view[:3, :3].T, np.eye(3), atol=1e-12)
    assert np.linalg.det(view[:3, :3]) == pytest.approx(1.0)      # right-handed
    proj = cam.projection(0.1, 10.0)
    clip = proj @ tv
    assert np.allclose(clip[:2] / clip[3], 0.0, atol=1e-12)
    above = proj @ view @ np.r_[cam.target + [0, 0.1, 0], 1.0]
    right = proj @ view @ np.r_[cam.target + [0.1, 0, 0], 1.0]
    assert above[1] / above[3] > 0 and right[0] / right[3] > 0     # y up, x right on screen


def test_projection_maps_near_and_far_planes_and_fov():
    cam = Camera(eye=[0, 0, 0], target=[0, 0, -1], up=[0, 1, 0], fov_y_deg=90.0,
                 width=200, height=100)
    proj = cam.projection(0.5, 20.0)
    for z, ndc in ((-0.5, -1.0), (-20.0, 1.0)):
        p = proj @ [0, 0, z, 1]
        assert p[2] / p[3] == pytest.approx(ndc)
    top = proj @ [0, 1, -1, 1]                                   # 45 degrees up: the top edge
    side = proj @ [2, 0, -1, 1]                                  # aspect 2: the right edge
    assert top[1] / top[3] == pytest.approx(1.0) and side[0] / side[3] == pytest.approx(1.0)


@pytest.mark.parametrize("near, far, match", [
    (0.0, 10.0, r"near: expected a number in \(0, inf\)"),
    (5.0, 1.0, r"projection: near=5.0 must be < far=1.0"),
])
def test_projection_rejects_bad_planes(ring_scene, near, far, match):
    with pytest.raises(InputError, match=match):
        ring_scene.camera.projection(near, far)


# --------------------------------------------------------------------------- dataclasses

def test_dataclasses_are_frozen_with_readonly_arrays(ring_scene):
    with pytest.raises(dataclasses.FrozenInstanceError):
        ring_scene.camera.fov_y_deg = 10.0
    with pytest.raises(ValueError, match="read-only"):
        ring_scene.camera.eye[0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        ring_scene.lights[0].power[0] = 1.0


def test_built_in_code_errors_name_the_class():
    with pytest.raises(InputError, match=r"Camera\.up: up \(0, 1, 0\) is parallel"):
        Camera(eye=[0, 2, 0], target=[0, 0, 0], up=[0, 1, 0], fov_y_deg=40, width=8, height=8)
    with pytest.raises(InputError, match=r"PhongMaterial\.ks: kd \+ ks = \(1\.1, 1\.1, 1\.1\)"):
        PhongMaterial(kd=0.6, ks=0.5, n=10)
    with pytest.raises(InputError, match=r"SceneObject\.mesh: the mesh is empty"):
        SceneObject(name="x", mesh=trimesh.Trimesh(), material=MirrorMaterial(reflectance=1.0))
    with pytest.raises(InputError, match=r"PhotonSettings\.k: expected an integer in 1 \.\. 10"):
        PhotonSettings(count=10, k=50)


def test_spot_light_direction_is_normalised():
    s = SpotLight(position=[0, 2, 0], direction=[0, -3, 0], power=5.0, cone_deg=30.0)
    assert s.direction.tolist() == [0.0, -1.0, 0.0]
    assert s.power.tolist() == [5.0, 5.0, 5.0]
    assert s.solid_angle == pytest.approx(2 * np.pi * (1 - np.cos(np.radians(30))))


# --------------------------------------------------------------------------- parsing

BASE = """\
[camera]
eye = [0.0, 1.9, 1.6]
target = [0.0, 0.0, 0.05]
fov_y_deg = 38.0
width = 64
height = 48

[materials.floor]
kind = "phong"
kd = 0.55
ks = 0.25
n = 20

[materials.mirror]
kind = "mirror"
reflectance = [0.95, 0.78, 0.45]

[[lights]]
kind = "point"
position = [-2.0, 1.0, 0.0]
power = 100.0

[[objects]]
name = "floor"
material = "floor"
[objects.shape]
kind = "rectangle"
x = [-1.5, 1.5]
z = [-1.5, 1.5]

[[objects]]
name = "ring"
material = "mirror"
[objects.shape]
kind = "ring"
inner_radius = 0.5
outer_radius = 0.53
height = 0.3
segments = 32

[photons]
count = 100
k = 10
"""

SPOT = """\
[[lights]]
kind = "spot"
position = [0.0, 2.0, 0.0]
direction = [0.0, -1.0, 0.0]
power = 50.0
cone_deg = 30.0
"""

FILE = "scenes/test.toml"


def _parse(text, path=FILE):
    return parse_scene(text, path=Path(path))


def _edit(old, new, text=BASE):
    assert old in text, old
    return text.replace(old, new, 1)


def test_base_scene_parses_with_defaults():
    s = _parse(BASE)
    assert s.camera.up.tolist() == [0.0, 1.0, 0.0]                 # default up
    assert s.objects[0].material.kd.tolist() == [0.55] * 3        # a number is grey
    assert s.photons == PhotonSettings(count=100, k=10, A=8, seed=1, max_bounces=4)
    assert s.path == Path(FILE) and s.description == ""
    assert len(s.objects[1].mesh.faces) == 3 * 2 * 32


def test_spot_light_parses():
    s = _parse(_edit('[[lights]]\nkind = "point"', SPOT + '\n[[lights]]\nkind = "point"'))
    spot, point = s.lights
    assert isinstance(spot, SpotLight) and spot.cone_deg == 30.0
    assert isinstance(point, PointLight)
    assert "spot at (0, 2, 0) along (0, -1, 0), cone 30 deg" in s.summary()


def test_scene_without_specular_object_loads():
    text = BASE[:BASE.index('[[objects]]\nname = "ring"')] + "\n[photons]\ncount = 100\n"
    s = _parse(text)
    assert s.specular_objects == () and [o.name for o in s.diffuse_objects] == ["floor"]
    assert "no caustics" in s.summary()


def test_object_placement_scales_rotates_and_translates_vertices_and_normals():
    text = _edit('name = "floor"\nmaterial = "floor"',
                 'name = "floor"\nmaterial = "floor"\nscale = 2.0\nrotate_deg = [0.0, 0.0, 90.0]\n'
                 'translate = [1.0, 0.0, 0.0]')
    floor = _parse(text).objects[0].mesh
    # +y turns to -x about z; the plane x=..., y in [-3, 3], z in [-3, 3], moved to x = 1
    assert np.allclose(floor.vertex_normals, [-1.0, 0.0, 0.0])
    assert np.allclose(floor.bounds, [[1.0, -3.0, -3.0], [1.0, 3.0, 3.0]])


# errors: (old text, new text, message pattern after "scenes/test.toml: ")
ERRORS = {
    "unknown material": ('material = "mirror"', 'material = "gold"',
                         r"objects\[1\]\.material: unknown material 'gold'; defined materials: "
                         r"floor, mirror; define \[materials\.gold\]"),
    "unknown camera key": ("fov_y_deg = 38.0", "fov = 38.0",
                           r"camera\.fov: unknown key \(did you mean 'fov_y_deg'\?\); allowed keys"),
    "unknown top-level table": ("[photons]", "[photon]",
                                r"photon: unknown key \(did you mean 'photons'\?\)"),
    "unknown photons key": ("k = 10", "k = 10\nA_ = 3", r"photons\.A_: unknown key"),
    "unknown shape key": ("segments = 32", "segments = 32\nradius = 1.0",
                          r"objects\[1\]\.shape\.radius: unknown key \(did you mean 'outer_radius'\?\); "
                          r"allowed keys here: kind, inner_radius, outer_radius, height, segments"),
    "missing camera key": ("eye = [0.0, 1.9, 1.6]\n", "",
                           r"camera\.eye: missing required key; the camera needs eye, target"),
    "missing table": ("[camera]", "[kamera]", r"kamera: unknown key \(did you mean 'camera'\?\)"),
    "float for integer": ("width = 64", "width = 64.0",
                          r"camera\.width: expected an integer; got 64\.0 \(float\); write it without"),
    "string for integer": ("width = 64", 'width = "64"',
                           r"camera\.width: expected an integer; got '64' \(string\)"),
    "string for number": ("fov_y_deg = 38.0", 'fov_y_deg = "wide"',
                          r"camera\.fov_y_deg: expected a number; got 'wide' \(string\)"),
    "boolean for number": ("power = 100.0", "power = true",
                           r"lights\[0\]\.power: expected a number; got True \(boolean\)"),
    "short vector": ("eye = [0.0, 1.9, 1.6]", "eye = [0.0, 1.9]",
                     r"camera\.eye: expected an array of 3 numbers \[x, y, z\] \(metres\); "
                     r"got \[0\.0, 1\.9\] \(array\)"),
    "infinite coordinate": ("eye = [0.0, 1.9, 1.6]", "eye = [0.0, inf, 1.6]",
                            r"camera\.eye\[1\]: expected a finite number; got inf"),
    "nan power": ("power = 100.0", "power = [100.0, nan, 100.0]",
                  r"lights\[0\]\.power\[1\]: expected a finite number; got nan"),
    "zero ring height": ("height = 0.3", "height = 0.0",
                         r"objects\[1\]\.shape\.height: expected a number in \(0, inf\); got 0\.0"),
    "negative image size": ("width = 64", "width = -5",
                            r"camera\.width: expected an integer in 1 \.\. 16,384; got -5"),
    "fov out of range": ("fov_y_deg = 38.0", "fov_y_deg = 180.0",
                         r"camera\.fov_y_deg: expected a number in \(0, 180\); got 180\.0"),
    "inner radius above outer": ("inner_radius = 0.5", "inner_radius = 0.6",
                                 r"objects\[1\]\.shape: ring: inner_radius=0\.6 must be < "
                                 r"outer_radius=0\.53"),
    "reversed rectangle": ("x = [-1.5, 1.5]", "x = [1.5, -1.5]",
                           r"objects\[0\]\.shape\.x: expected \[min, max\] with min < max"),
    "unknown shape kind": ('kind = "ring"', 'kind = "torus"',
                           r"objects\[1\]\.shape\.kind: expected one of 'rectangle', 'ring', "
                           r"'sphere', 'bust'; got 'torus'"),
    "up parallel to view": ("target = [0.0, 0.0, 0.05]", "target = [0.0, 0.0, 0.05]\n"
                            "up = [0.0, -1.9, -1.55]",
                            r"camera\.up: up \(0, -1\.9, -1\.55\) is parallel to the view "
                            r"direction .*; for a camera looking straight down use"),
    "zero up": ("target = [0.0, 0.0, 0.05]", "target = [0.0, 0.0, 0.05]\nup = [0, 0, 0]",
                r"camera\.up: expected a non-zero direction"),
    "eye equals target": ("target = [0.0, 0.0, 0.05]", "target = [0.0, 1.9, 1.6]",
                          r"camera\.target: target \(0, 1\.9, 1\.6\) equals eye"),
    "energy not conserved": ("kd = 0.55", "kd = [0.55, 0.8, 0.55]",
                             r"materials\.floor\.ks: kd \+ ks = \(0\.8, 1\.05, 0\.8\) exceeds 1 "
                             r"in channel g"),
    "reflectance above one": ("reflectance = [0.95, 0.78, 0.45]", "reflectance = [1.2, 0.78, 0.45]",
                              r"materials\.mirror\.reflectance\[0\]: expected a number in \[0, 1\]; "
                              r"got 1\.2"),
    "negative kd": ("kd = 0.55", "kd = -0.1", r"materials\.floor\.kd: expected a number in \[0, inf\)"),
    "phong without exponent": ("n = 20\n", "",
                               r"materials\.floor\.n: missing required key; a phong material with "
                               r"ks > 0 needs the exponent n"),
    "unknown material kind": ('kind = "mirror"', 'kind = "glass"',
                              r"materials\.mirror\.kind: expected one of 'phong', 'mirror', 'dielectric'; "
                              r"got 'glass'"),
    "mirror with phong key": ("reflectance = [0.95, 0.78, 0.45]",
                              "reflectance = [0.95, 0.78, 0.45]\nkd = 0.5",
                              r"materials\.mirror\.kd: unknown key"),
    "unknown light kind": ('kind = "point"', 'kind = "area"',
                           r"lights\[0\]\.kind: expected one of 'point', 'spot', 'directional', 'environment'; got 'area'"),
    "light without power": ("power = 100.0", "power = 0.0",
                            r"lights\[0\]\.power: the light emits nothing"),
    "point light with cone": ("power = 100.0", "power = 100.0\ncone_deg = 20.0",
                              r"lights\[0\]\.cone_deg: unknown key; allowed keys here: kind, "
                              r"position, power"),
    "lights as a table": ('[[lights]]\nkind = "point"', '[lights]\nkind = "point"',
                          r"lights: expected an array of tables, written \[\[lights\]\]"),
    "mesh and shape": ('name = "ring"', 'name = "ring"\nmesh = "ring.obj"',
                       r"objects\[1\]: expected exactly one of mesh = \"file\.obj\" or an "
                       r"\[objects\.shape\] table; got both"),
    "normals on a shape": ('name = "ring"', 'name = "ring"\nnormals = "flat"',
                           r"objects\[1\]\.normals: normals applies to mesh files only"),
    "duplicate object name": ('name = "ring"', 'name = "floor"',
                              r"objects\[1\]\.name: duplicate object name 'floor' \(also "
                              r"objects\[0\]\)"),
    "k above count": ("k = 10", "k = 200",
                      r"photons\.k: expected an integer in 1 \.\. 100; got 200; k cannot exceed"),
    "zero photons": ("count = 100", "count = 0", r"photons\.count: expected an integer >= 1; got 0"),
    "negative scale": ('name = "ring"', 'name = "ring"\nscale = -1.0',
                       r"objects\[1\]\.scale: expected a number in \(0, inf\); got -1\.0"),
    "bad rotation": ('name = "ring"', 'name = "ring"\nrotate_deg = 90.0',
                     r"objects\[1\]\.rotate_deg: expected an array of 3 numbers \[x, y, z\] "
                     r"\(degrees\)"),
    "toml syntax": ("width = 64", "width = = 64", r"TOML syntax error: .*line 5"),
}


@pytest.mark.parametrize("old, new, match", ERRORS.values(), ids=ERRORS.keys())
def test_errors_name_file_key_and_problem(old, new, match):
    with pytest.raises(InputError, match=r"^scenes/test\.toml: " + match):
        _parse(_edit(old, new))


def test_scene_needs_a_light():
    text = "lights = []\n" + _edit('[[lights]]\nkind = "point"\nposition = [-2.0, 1.0, 0.0]\n'
                                   'power = 100.0\n', "")
    with pytest.raises(InputError, match=r"^scenes/test\.toml: lights: expected at least one "
                                         r"\[\[lights\]\] table \(a light\); got none"):
        _parse(text)
    with pytest.raises(InputError, match=r"^scenes/test\.toml: lights: the scene has no light; "
                                         r"add a \[\[lights\]\] table or an object with emission"):
        _parse(text[len("lights = []\n"):])


def test_spot_light_errors():
    text = _edit('[[lights]]\nkind = "point"', SPOT + '\n[[lights]]\nkind = "point"')
    with pytest.raises(InputError, match=r"^scenes/test\.toml: lights\[0\]\.cone_deg: expected a "
                                         r"number in \(0, 90\]; got 120\.0; cone_deg is the half"):
        _parse(_edit("cone_deg = 30.0", "cone_deg = 120.0", text))
    with pytest.raises(InputError, match=r"lights\[0\]\.direction: expected a non-zero direction"):
        _parse(_edit("direction = [0.0, -1.0, 0.0]", "direction = [0.0, 0.0, 0.0]", text))
    with pytest.raises(InputError, match=r"lights\[0\]\.direction: missing required key; a spot "
                                         r"light needs kind, position, direction, power, cone_deg"):
        _parse(_edit("direction = [0.0, -1.0, 0.0]\n", "", text))


def test_error_without_a_file_says_string():
    with pytest.raises(InputError, match=r"^<string>: camera\.width: expected an integer"):
        parse_scene(_edit("width = 64", "width = 64.5"))


def test_missing_scene_file():
    with pytest.raises(InputError, match=r"nowhere\.toml: scene file not found .*; give the path"):
        load_scene("nowhere.toml")
    with pytest.raises(InputError, match=r"is a directory, not a scene file"):
        load_scene(SCENES)


# --------------------------------------------------------------------------- mesh files

def _with_mesh(path_text, extra=""):
    return _edit('[objects.shape]\nkind = "ring"\ninner_radius = 0.5\nouter_radius = 0.53\n'
                 'height = 0.3\nsegments = 32\n', f'mesh = "{path_text}"\n{extra}')


OBJ_TILTED = """\
v 0 0 0
v 1 0 0
v 1 0 1
v 0 0 1
vn 0 0.6 0.8
f 1//1 3//1 2//1
f 1//1 4//1 3//1
"""


@pytest.fixture
def scene_dir(tmp_path):
    folder = tmp_path / "sub"
    (folder / "meshes").mkdir(parents=True)
    (folder / "meshes" / "quad.obj").write_text(OBJ_TILTED)
    trimesh.creation.icosphere(subdivisions=2).export(folder / "meshes" / "ball.stl")
    (folder / "meshes" / "empty.obj").write_text("v 0 0 0\nv 1 0 0\n")
    return folder


def _load_in(folder, text):
    path = folder / "scene.toml"
    path.write_text(text)
    return load_scene(path)


def test_mesh_file_is_resolved_relative_to_the_scene_and_keeps_its_normals(scene_dir):
    quad = _by_name(_load_in(scene_dir, _with_mesh("meshes/quad.obj")), "ring").mesh
    assert len(quad.faces) == 2
    assert np.allclose(quad.vertex_normals, [0.0, 0.6, 0.8])      # the file's, not the faces'
    assert np.allclose(quad.face_normals, [0.0, 1.0, 0.0])


@pytest.mark.parametrize("mode, expected", [("flat", [0.0, 1.0, 0.0]), ("smooth", [0.0, 1.0, 0.0])])
def test_mesh_normals_modes(scene_dir, mode, expected):
    quad = _by_name(_load_in(scene_dir, _with_mesh("meshes/quad.obj", f'normals = "{mode}"')),
                    "ring").mesh
    assert np.allclose(quad.vertex_normals, expected)
    assert len(quad.vertices) == (6 if mode == "flat" else 4)


def test_stl_without_normals_gets_smooth_normals(scene_dir):
    ball = _by_name(_load_in(scene_dir, _with_mesh(str(scene_dir / "meshes" / "ball.stl"))),
                    "ring").mesh
    assert ball.is_watertight                                     # merged: one smooth surface
    radial = ball.vertices / np.linalg.norm(ball.vertices, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", ball.vertex_normals, radial).min() > 0.98


@pytest.mark.parametrize("mesh, match", [
    ("meshes/missing.obj", r"objects\[1\]\.mesh: mesh file not found: '.*missing\.obj' "
                           r"\('meshes/missing\.obj' is resolved relative to the scene file's folder"),
    ("meshes/empty.obj", r"objects\[1\]\.mesh: the mesh file '.*empty\.obj' has no triangles"),
    ("meshes/quad.fbx", r"objects\[1\]\.mesh: unsupported mesh file type '\.fbx'.*expected one of "
                        r"\.obj, \.ply, \.stl"),
])
def test_mesh_file_errors(scene_dir, mesh, match):
    with pytest.raises(InputError, match=r"scene\.toml: " + match):
        _load_in(scene_dir, _with_mesh(mesh))


def test_scene_objects_reject_wrong_types():
    cam = Camera(eye=[0, 1, 1], target=[0, 0, 0], up=[0, 1, 0], fov_y_deg=40, width=8, height=8)
    obj = SceneObject(name="r", mesh=meshes.ring(0.5, 0.53, 0.3, 8),
                      material=MirrorMaterial(reflectance=0.9))
    with pytest.raises(InputError, match=r"Scene\.lights: the scene has no light"):
        Scene(camera=cam, lights=(), objects=(obj,))
    with pytest.raises(InputError, match=r"SceneObject\.material: expected a PhongMaterial, "
                                         r"MirrorMaterial or DielectricMaterial; got str"):
        SceneObject(name="r", mesh=obj.mesh, material="mirror")


@pytest.mark.parametrize("cone, beam", [(30.0, 30.0), (30.0, 22.5), (20.0, 8.0), (90.0, 1.0)])
def test_a_spots_falloff_integrates_to_its_solid_angle_and_its_power(cone, beam):
    from blockhash.scene.lights import SpotLight

    spot = SpotLight(position=(0, 1, 0), direction=(0, -1, 0), power=5.0, cone_deg=cone, beam_deg=beam)
    theta = (np.arange(200_000) + 0.5) * (np.pi / 200_000)
    integral = 2 * np.pi * np.sum(spot.falloff(np.cos(theta)) * np.sin(theta)) * (np.pi / 200_000)
    assert integral == pytest.approx(spot.falloff_solid_angle, rel=1e-4)
    assert (spot.peak_intensity * integral == pytest.approx(spot.power, rel=1e-4))
    assert spot.falloff(np.cos(np.radians([0.0, beam * 0.999, cone * 1.001]))).tolist()[::2] == [1.0, 0.0]
    mid = np.radians(0.5 * (beam + cone))
    if beam < cone:
        assert spot.falloff(np.cos(mid)) == pytest.approx(0.5, rel=1e-9)


def test_a_spots_beam_is_read_and_checked_from_toml():
    from blockhash.errors import InputError
    from blockhash.scene.loader import parse_scene

    base = (Path(__file__).resolve().parents[2] / "scenes" / "ring.toml").read_text()
    light = ('[[lights]]\nkind = "spot"\nposition = [-2.0, 1.0, 0.0]\ndirection = [1.0, -0.4, 0.0]\n'
             'power = 100.0\ncone_deg = 30.0\n')
    text = base.replace(base[base.index("[[lights]]"):base.index("[[objects]]")], light + "beam_deg = 20.0\n")
    spot = parse_scene(text).lights[0]
    assert spot.beam_deg == 20.0 and not spot.uniform
    with pytest.raises(InputError, match=r"beam_deg.*expected a number in \(0, 30\]"):
        parse_scene(text.replace("beam_deg = 20.0", "beam_deg = 40.0"))


def test_a_crop_window_is_part_of_the_whole_films_view(tmp_path):
    """``[camera] crop``: the image is that part of the film whose field of view is
    fov_y_deg: its pixels' rays are the whole film's rays through the same film points, and a
    world point projects to the same film point."""
    from blockhash.scene.camera import Pinhole

    text = (SCENES / "ring.toml").read_text()
    path = tmp_path / "crop.toml"
    path.write_text(text.replace("[camera]", "[camera]\ncrop = [0.25, 0.5, 0.75, 1.0]", 1))
    scene = load_scene(path)
    assert scene.camera.crop == (0.25, 0.5, 0.75, 1.0)
    part = Pinhole.of(scene.camera, (24, 24))
    whole = Pinhole.of(dataclasses.replace(scene.camera, crop=None), (48, 48))
    x, y = np.random.default_rng(2).uniform(0, 24, (2, 50))
    np.testing.assert_allclose(part.film_rays(x, y), whole.film_rays(x + 12, y + 24), atol=1e-12)
    points = scene.camera.eye + 3.0 * whole.film_rays(x + 12, y + 24)
    fx, fy, _ = part.film_coords(points)
    np.testing.assert_allclose(np.c_[fx, fy], np.c_[x, y], atol=1e-9)
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    back = load_scene(export_mitsuba(scene, tmp_path / "xml", drop_specular=True)).camera
    assert back.crop == scene.camera.crop and (back.width, back.height) == (scene.camera.width,
                                                                           scene.camera.height)
    assert back.fov_y_deg == pytest.approx(scene.camera.fov_y_deg)
    for bad in ("[0.5, 0.0, 0.25, 1.0]", "[0.0, 0.0, 1.0, 1.5]", "[0.1, 0.2]"):
        path.write_text(text.replace("[camera]", f"[camera]\ncrop = {bad}", 1))
        with pytest.raises(InputError, match=r"camera\.crop: expected"):
            load_scene(path)


def test_a_thin_lens_sees_its_focus_plane_sharp_and_the_light_tracer_refuses_it(tmp_path):
    """``aperture_radius`` and ``focus_distance``: every lens ray through a film point meets
    the pinhole's ray through it at the plane in focus, the rays start on the lens's disc, a
    Mitsuba export and import keep the lens, and the light tracer (a pinhole's reference)
    refuses it by name."""
    from blockhash.reference.lighttrace import light_trace
    from blockhash.scene.camera import Pinhole
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    text = (SCENES / "ring.toml").read_text()
    path = tmp_path / "lens.toml"
    path.write_text(text.replace("[camera]", "[camera]\naperture_radius = 0.2\nfocus_distance = 3.0", 1))
    scene = load_scene(path)
    pin = Pinhole.of(scene.camera, (32, 24))
    x, y = np.random.default_rng(3).uniform(0, 24, (2, 400))
    origins, dirs = pin.lens_rays(x, y, seed=5)
    pinhole = pin.film_rays(x, y)
    t = (3.0 - (origins - pin.eye) @ pin.forward) / (dirs @ pin.forward)
    sharp = pin.eye + pinhole * (3.0 / (pinhole @ pin.forward))[:, None]
    np.testing.assert_allclose(origins + dirs * t[:, None], sharp, atol=1e-9)
    offset = origins - pin.eye
    assert np.abs(offset @ pin.forward).max() < 1e-12
    assert np.linalg.norm(offset, axis=1).max() <= 0.2 + 1e-12
    assert np.linalg.norm(offset, axis=1).mean() > 0.1  # spread over the disc
    back = load_scene(export_mitsuba(scene, tmp_path / "xml", drop_specular=True)).camera
    assert (back.aperture_radius, back.focus_distance) == (0.2, 3.0)
    with pytest.raises(InputError, match="light tracer connects photons to a pinhole.*Mitsuba"):
        light_trace(scene, 1000)
    path.write_text(text.replace("[camera]", "[camera]\naperture_radius = -1", 1))
    with pytest.raises(InputError, match=r"camera\.aperture_radius"):
        load_scene(path)
