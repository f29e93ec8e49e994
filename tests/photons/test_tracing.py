"""Caustic photon tracing against analytic scenes (blockhash.photons.tracing)."""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import trimesh

from blockhash.errors import InputError
from blockhash.photons.tracing import (
    FATE_NAMES,
    RAY_OFFSET,
    CausticPhotons,
    PhotonSource,
    TracingWarning,
    no_caustic_reason,
    trace_caustic_photons,
)
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

GREY = PhongMaterial(kd=np.array([0.5, 0.5, 0.5]), ks=np.array([0.2, 0.2, 0.2]), n=20.0)
REFL = np.array([0.9, 0.6, 0.3])
UP = np.array([0.0, 1.0, 0.0])


def quad(corners, normal) -> trimesh.Trimesh:
    """Two triangles over 4 corners (counter-clockwise seen from ``normal``), flat normals."""
    v = np.asarray(corners, dtype=np.float64)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    if np.cross(v[1] - v[0], v[2] - v[0]) @ normal < 0:
        faces = faces[:, ::-1]
    return trimesh.Trimesh(v, faces, vertex_normals=np.tile(normal, (4, 1)), process=False)


def horizontal(y, half_x, half_z, normal=UP, cx=0.0, cz=0.0):
    return quad([[cx - half_x, y, cz - half_z], [cx + half_x, y, cz - half_z],
                 [cx + half_x, y, cz + half_z], [cx - half_x, y, cz + half_z]], np.asarray(normal, float))


def ring_mesh(r_in=0.5, r_out=0.53, height=0.3, segments=256, smooth=True) -> trimesh.Trimesh:
    """Cylindrical shell on y=0: inner/outer walls and a flat top rim, each with its own vertices.

    ``smooth``: radial vertex normals on the walls (a round ring); otherwise every
    triangle gets its own vertices carrying its face normal (a faceted ring).
    """
    a = 2 * np.pi * np.arange(segments) / segments
    c, s, zero = np.cos(a), np.sin(a), np.zeros(segments)
    radial = np.stack([c, zero, s], 1)
    verts, norms, faces = [], [], []

    def add_strip(p0, p1, n0, n1):
        base = sum(len(x) for x in verts)
        verts.extend([p0, p1])
        norms.extend([n0, n1])
        i = np.arange(segments)
        j = (i + 1) % segments
        lo0, lo1, hi0, hi1 = base + i, base + j, base + segments + i, base + segments + j
        faces.append(np.concatenate([np.stack([lo0, hi0, lo1], 1), np.stack([lo1, hi0, hi1], 1)]))

    for r, sign in ((r_out, 1.0), (r_in, -1.0)):
        low = np.stack([r * c, zero, r * s], 1)
        add_strip(low, low + [0.0, height, 0.0], sign * radial, sign * radial)
    up = np.tile(UP, (segments, 1))
    add_strip(np.stack([r_in * c, zero + height, r_in * s], 1),
              np.stack([r_out * c, zero + height, r_out * s], 1), up, up)
    v, n, f = np.concatenate(verts), np.concatenate(norms), np.concatenate(faces)
    # wind every triangle so that its face normal agrees with the wanted normals
    e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    flip = np.einsum("ij,ij->i", e, n[f].sum(1)) < 0
    f[flip] = f[flip][:, ::-1]
    if not smooth:
        e = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        e /= np.linalg.norm(e, axis=1, keepdims=True)
        v, n, f = v[f].reshape(-1, 3), np.repeat(e, 3, axis=0), np.arange(3 * len(f)).reshape(-1, 3)
    return trimesh.Trimesh(v, f, vertex_normals=n, process=False)


def make_scene(objects, lights, *, count=2000, seed=3, max_bounces=4, path=Path("test.toml")):
    cam = Camera(eye=(0.0, 2.0, 2.0), target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0),
                 fov_y_deg=40.0, width=64, height=64)
    photons = PhotonSettings(count=count, k=50, A=8, seed=seed, max_bounces=max_bounces)
    return Scene(camera=cam, lights=tuple(lights), objects=tuple(objects), photons=photons, path=path)


def rect_solid_angle(a, b, d):
    """Solid angle of a 2a x 2b rectangle seen from distance d above its centre."""
    return 4.0 * math.atan(a * b / (d * math.sqrt(d * d + a * a + b * b)))


def floor_solid_angle(xr, zr, height, cone=None, m=1500):
    """Solid angle of the rectangle xr x zr of the plane y=0 seen from (0, height, 0),
    optionally only its part inside ``cone = (unit axis, cos half-angle)``, by midpoint
    quadrature (an oracle independent of the tracer's cone sampling)."""
    x = xr[0] + (np.arange(m) + 0.5) / m * (xr[1] - xr[0])
    z = zr[0] + (np.arange(m) + 0.5) / m * (zr[1] - zr[0])
    X, Z = np.meshgrid(x, z)
    w = np.stack([X, -np.full_like(X, height), Z], -1)
    dist = np.linalg.norm(w, axis=-1)
    inside = np.ones(X.shape, dtype=bool) if cone is None else (w @ cone[0]) / dist >= cone[1]
    dA = (xr[1] - xr[0]) * (zr[1] - zr[0]) / m**2
    return float(np.sum(inside * height / dist**3) * dA)


def relative_sigma(result: CausticPhotons) -> float:
    """Monte Carlo relative standard deviation of the stored flux (binomial, equal weights)."""
    p = len(result) / result.emitted
    return math.sqrt((1.0 - p) / len(result))


# Mirror (reflectance REFL) at y=0 facing up, half-sides A x B, light at height D above it;
# the receiver is a large diffuse ceiling at y=2 facing down that catches every reflection.
A_HALF, B_HALF, D_LIGHT = 0.4, 0.25, 1.0


def mirror_and_ceiling():
    mirror = SceneObject("mirror", horizontal(0.0, A_HALF, B_HALF), MirrorMaterial(REFL))
    ceiling = SceneObject("ceiling", horizontal(2.0, 10.0, 10.0, normal=-UP), GREY)
    return [mirror, ceiling]


def test_point_light_flux_matches_mirror_solid_angle():
    power = np.array([100.0, 50.0, 20.0])
    scene = make_scene(mirror_and_ceiling(), [PointLight((0.0, D_LIGHT, 0.0), power)])
    res = trace_caustic_photons(scene, 20000, seed=11)
    expected = REFL * power * rect_solid_angle(A_HALF, B_HALF, D_LIGHT) / (4 * np.pi)
    tol = 5 * relative_sigma(res)
    assert tol < 0.025  # sharp enough to catch a missing cos or reflectance factor
    np.testing.assert_allclose(res.total_power, expected, rtol=tol)
    assert len(res) == 20000 and res.stats["stored"] == 20000
    assert res.stats["max_depth_reached"] == 1


@pytest.mark.parametrize("axis, cone_deg", [
    ((0.0, -1.0, 0.0), 10.0),   # spot cone inside the mirror: all light reflected
    ((0.0, -1.0, 0.0), 60.0),   # mirror inside the spot cone
    ((0.3, -1.0, 0.1), 20.0),   # partial overlap, spot cone the smaller: spot sampled
    ((0.7, -1.0, 0.0), 30.0),   # partial overlap, mirror cone the smaller: clipped by the spot
])
@pytest.mark.slow
def test_spot_light_flux_matches_integral_over_mirror(axis, cone_deg):
    power = np.array([40.0, 40.0, 40.0])
    axis = np.asarray(axis) / np.linalg.norm(axis)
    light = SpotLight(position=(0.0, D_LIGHT, 0.0), direction=tuple(axis), power=power, cone_deg=cone_deg)
    scene = make_scene(mirror_and_ceiling(), [light])
    res = trace_caustic_photons(scene, 20000, seed=5)
    omega = floor_solid_angle((-A_HALF, A_HALF), (-B_HALF, B_HALF), D_LIGHT,
                              cone=(axis, math.cos(math.radians(cone_deg))))
    spot_sa = 2 * np.pi * (1 - math.cos(math.radians(cone_deg)))
    expected = REFL * power * omega / spot_sa
    tol = 5 * relative_sigma(res) + 2e-3  # 2e-3: quadrature error along the cone's edge
    np.testing.assert_allclose(res.total_power, expected, rtol=tol)


def test_overlapping_cones_of_two_mirrors_are_not_counted_twice():
    """Two mirrors side by side: each one's bounding cone covers part of the other."""
    r1, r2 = np.array([0.9, 0.9, 0.9]), np.array([0.5, 0.4, 0.3])
    # long thin strips along z: each one's round cone reaches well over the other
    m1 = SceneObject("left", horizontal(0.0, 0.09, 0.6, cx=-0.11), MirrorMaterial(r1))
    m2 = SceneObject("right", horizontal(0.0, 0.09, 0.6, cx=0.11), MirrorMaterial(r2))
    ceiling = SceneObject("ceiling", horizontal(2.0, 10.0, 10.0, normal=-UP), GREY)
    power = np.array([30.0, 30.0, 30.0])
    res = trace_caustic_photons(make_scene([m1, m2, ceiling], [PointLight((0.0, 1.0, 0.0), power)]),
                                20000, seed=8)
    cones = res.stats["cones"]
    between_axes = 2 * math.degrees(math.atan(0.11))
    assert len(cones) == 2 and cones[0]["half_angle_deg"] + cones[1]["half_angle_deg"] > between_axes
    omega = floor_solid_angle((0.02, 0.2), (-0.6, 0.6), 1.0)  # each mirror, by symmetry
    expected = power * (r1 + r2) * omega / (4 * np.pi)
    np.testing.assert_allclose(res.total_power, expected, rtol=8 * relative_sigma(res))


def test_flux_does_not_depend_on_light_split():
    """Two lights: the budget splits by power into the cones, the flux still adds up."""
    p1, p2 = np.array([100.0, 100.0, 100.0]), np.array([10.0, 20.0, 30.0])
    lights = [PointLight((0.0, D_LIGHT, 0.0), p1), PointLight((0.0, 0.5, 0.0), p2)]
    res = trace_caustic_photons(make_scene(mirror_and_ceiling(), lights), 20000, seed=2)
    expected = REFL * (p1 * rect_solid_angle(A_HALF, B_HALF, 1.0)
                       + p2 * rect_solid_angle(A_HALF, B_HALF, 0.5)) / (4 * np.pi)
    # unequal photon powers: allow a little more than the equal-weight binomial bound
    np.testing.assert_allclose(res.total_power, expected, rtol=8 * relative_sigma(res))
    n1, n2 = res.stats["emitted_per_light"]
    share = rect_solid_angle(A_HALF, B_HALF, 1.0) * 100 / (
        rect_solid_angle(A_HALF, B_HALF, 1.0) * 100 + rect_solid_angle(A_HALF, B_HALF, 0.5) * 20)
    assert n1 / (n1 + n2) > 0.5 and n2 > 0
    pmf = [c["pmf"] for c in res.stats["cones"]]
    # cone pmf follows power x cone solid angle, which is close to the mirrors' share
    assert abs(pmf[0] - share) < 0.1


def test_stored_photons_lie_on_reflected_rays_of_a_flat_mirror():
    # vertical mirror in the plane x=0 facing +x, floor y=0, light in front of the mirror
    mirror = quad([[0.0, 0.05, -0.4], [0.0, 0.05, 0.4], [0.0, 1.0, 0.4], [0.0, 1.0, -0.4]],
                  np.array([1.0, 0.0, 0.0]))
    floor = horizontal(0.0, 4.0, 4.0)
    light = np.array([1.0, 0.5, 0.2])
    scene = make_scene([SceneObject("mirror", mirror, MirrorMaterial(REFL)),
                        SceneObject("floor", floor, GREY)], [PointLight(tuple(light), (10.0, 10.0, 10.0))])
    res = trace_caustic_photons(scene, 3000, seed=1)
    # the light mirrored in x=0; the reflected ray leaves from RAY_OFFSET x scene size off the
    # mirror along its normal, which moves the reflected line by that much along +x
    corners = np.concatenate([mirror.vertices, floor.vertices])
    offset = RAY_OFFSET * np.linalg.norm(corners.max(0) - corners.min(0))
    image = light * [-1.0, 1.0, 1.0] + [offset, 0.0, 0.0]
    p = res.positions
    np.testing.assert_allclose(p[:, 1], 0.0, atol=1e-9)
    assert np.all(p[:, 0] > 0)  # in front of the mirror
    # the line from the mirror image through the stored point crosses the mirror rectangle
    t = -image[0] / (p[:, 0] - image[0])
    cross = image + t[:, None] * (p - image)
    assert np.all((cross[:, 1] >= 0.05 - 1e-6) & (cross[:, 1] <= 1.0 + 1e-6))
    assert np.all(np.abs(cross[:, 2]) <= 0.4 + 1e-6)
    # ...and the photon travels along that line
    expected_dir = (p - image) / np.linalg.norm(p - image, axis=1, keepdims=True)
    np.testing.assert_allclose(res.directions, expected_dir, atol=1e-6)
    # unit vectors to float32's rounding (the device's kernels compute in float32)
    np.testing.assert_allclose(np.linalg.norm(res.directions, axis=1), 1.0, atol=3e-7)
    np.testing.assert_allclose(res.normals, np.tile(UP, (len(res), 1)), atol=3e-7)
    assert np.all(np.sum(res.normals * res.directions, axis=1) < 0)


def test_normals_face_the_side_the_photon_came_from():
    """A receiver whose triangles face away from the mirror still gets normals toward the photons."""
    objs = mirror_and_ceiling()
    objs[1] = SceneObject("ceiling", horizontal(2.0, 10.0, 10.0, normal=UP), GREY)  # faces up, lit from below
    res = trace_caustic_photons(make_scene(objs, [PointLight((0.0, 1.0, 0.0), (1.0, 1.0, 1.0))]), 500)
    np.testing.assert_allclose(res.normals, np.tile(-UP, (len(res), 1)), atol=1e-12)


def ring_scene(count=3000, segments=64, max_bounces=4, smooth=True):
    ring = SceneObject("ring", ring_mesh(segments=segments, smooth=smooth), MirrorMaterial(REFL))
    floor = SceneObject("floor", horizontal(0.0, 1.5, 1.5), GREY)
    light = PointLight((-2.0, 1.0, 0.0), (100.0, 100.0, 100.0))
    return make_scene([floor, ring], [light], count=count, max_bounces=max_bounces)


@pytest.mark.parametrize("smooth", [True, False])
def test_ring_reflects_about_smooth_radial_normals(smooth):
    """Photons inside the ring left the inner wall along the reflection about the radial normal.

    With faceted normals (``smooth=False``) the reflection is off by up to the half
    segment angle, so this test fails for them: it pins down the normal interpolation.
    """
    scene = ring_scene(count=4000, max_bounces=1, smooth=smooth)
    res = trace_caustic_photons(scene, seed=9)
    p, d = res.positions, res.directions
    np.testing.assert_allclose(p[:, 1], 0.0, atol=1e-9)
    inside = np.hypot(p[:, 0], p[:, 2]) < 0.5
    assert inside.mean() > 0.2
    ring = scene.objects[1].mesh
    loc, ray, _ = ring.ray.intersects_location(p[inside] + 1e-7 * UP, -d[inside], multiple_hits=False)
    assert len(ray) == inside.sum()
    q = np.empty_like(loc)
    q[ray] = loc
    radial = q * [1.0, 0.0, 1.0]
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    incident = q - scene.lights[0].position
    incident /= np.linalg.norm(incident, axis=1, keepdims=True)
    predicted = incident - 2 * np.sum(incident * radial, 1, keepdims=True) * radial
    err = np.linalg.norm(predicted - d[inside], axis=1)
    # 1e-3: reflected rays leave RAY_OFFSET x scene size (4e-5 m) off the wall, which turns
    # the back-traced wall point by up to ~2e-4 rad; faceted normals are off by up to 0.05 rad
    if smooth:
        assert err.max() < 1e-3
    else:
        assert np.mean(err < 1e-3) < 0.1


def test_same_photons_whatever_the_batch_size():
    scene = ring_scene(count=2000)
    a = trace_caustic_photons(scene, seed=4, batch_size=997)
    b = trace_caustic_photons(scene, seed=4, batch_size=65536)
    assert a.emitted == b.emitted and len(a) == len(b) == 2000
    for name in ("positions", "directions", "normals", "powers"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    deterministic = ("emitted", "hit_specular", "stored", "missed", "direct_diffuse", "escaped",
                     "exceeded_max_bounces", "max_depth_reached", "emitted_per_light")
    assert {k: a.stats[k] for k in deterministic} == {k: b.stats[k] for k in deterministic}
    assert a.stats["batches"] > b.stats["batches"]
    c = trace_caustic_photons(scene, seed=5, batch_size=997)
    assert not np.array_equal(a.positions, c.positions)


def test_ring_stats_account_for_every_photon():
    res = trace_caustic_photons(ring_scene(count=2000), seed=1)
    s = res.stats
    fates = ("stored", "outside_spot_cone", "missed", "direct_diffuse", "escaped", "absorbed",
             "exceeded_max_bounces")
    assert sum(s[f] for f in fates) == s["emitted"] == res.emitted
    assert s["hit_specular"] == s["emitted"] - s["missed"] - s["direct_diffuse"] - s["outside_spot_cone"]
    assert s["stopped_by"] == "target" and s["max_depth_reached"] >= 2
    assert s["direct_diffuse"] > 0 and s["missed"] > 0  # the cone also covers floor and sky


def test_scene_without_mirror_gives_empty_map():
    scene = make_scene([SceneObject("floor", horizontal(0.0, 1.0, 1.0), GREY)],
                       [PointLight((0.0, 1.0, 0.0), (1.0, 1.0, 1.0))])
    res = trace_caustic_photons(scene)
    assert len(res) == 0 and res.emitted == 0
    assert res.positions.shape == res.powers.shape == (0, 3)
    assert res.stats["stopped_by"] == "no_specular_objects"
    assert "no specular" in res.stats["reason"]


def duck_scene(scene, **changes):
    """A scene-like object that skips Scene's own checks (which refuse no lights, max_bounces 0)."""
    fields = {name: getattr(scene, name) for name in
              ("camera", "lights", "objects", "photons", "path", "specular_objects", "diffuse_objects")}
    return SimpleNamespace(**{**fields, **changes})


def test_scene_without_lights_is_an_error():
    scene = duck_scene(make_scene(mirror_and_ceiling(), [PointLight((0.0, 1.0, 0.0), (1.0, 1.0, 1.0))]),
                       lights=())
    with pytest.raises(InputError, match=r"scene 'test.toml' has no lights"):
        trace_caustic_photons(scene)


def occluded_mirror_scene():
    objs = mirror_and_ceiling() + [SceneObject("blocker", horizontal(0.5, 2.0, 2.0), GREY)]
    return make_scene(objs, [PointLight((0.0, D_LIGHT, 0.0), (1.0, 1.0, 1.0))])


def test_occluded_mirror_is_an_error_when_a_map_is_asked_for():
    with pytest.raises(InputError, match=r"scene 'test.toml': no caustic photon stored of 50,000 "
                                         r"shot toward the mirrors \['mirror'\] \(direct diffuse "
                                         r"50,000\); the mirrors are not reachable.*move the light"):
        trace_caustic_photons(occluded_mirror_scene(), 100, max_emitted=50_000)


def test_a_source_that_stores_nothing_answers_an_empty_map_without_a_warning():
    """PhotonSource.until_stored, the render's pass 0: no photon stored within the budget is
    an empty map that counts the photons shot and their fates; the render warns, not the
    tracer."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = PhotonSource(occluded_mirror_scene()).until_stored(100, max_emitted=50_000)
    assert isinstance(res, CausticPhotons) and len(res) == 0
    assert res.positions.shape == res.powers.shape == (0, 3)
    assert res.emitted == res.stats["emitted"] == 50_000
    s = res.stats
    assert s["stopped_by"] == "nothing_stored" and s["stored"] == 0
    assert s["direct_diffuse"] == 50_000  # the blocker takes every photon shot at the mirror
    assert sum(s[f] for f in FATE_NAMES) == 50_000
    assert s["specular_objects"] == ("mirror",)


def test_the_reason_names_the_photons_shot_the_mirrors_and_the_fates():
    res = PhotonSource(occluded_mirror_scene()).until_stored(100, max_emitted=20_000)
    assert no_caustic_reason(res.stats) == ("no caustic photon stored of 20,000 shot toward the "
                                            "mirrors ['mirror'] (direct diffuse 20,000)")
    stats = {"emitted": 1_048_576, "stored": 0, "missed": 1000, "direct_diffuse": 48_576,
             "escaped": 1_000_000, "absorbed": 0, "specular_objects": ("ring", "ball"),
             "stopped_by": "nothing_stored"}
    assert no_caustic_reason(stats) == ("no caustic photon stored of 1,048,576 shot toward the "
                                        "mirrors ['ring', 'ball'] (missed 1,000, direct diffuse "
                                        "48,576, escaped 1,000,000)")
    floor_only = make_scene([SceneObject("floor", horizontal(0.0, 1.0, 1.0), GREY)],
                            [PointLight((0.0, 1.0, 0.0), (1.0, 1.0, 1.0))])
    assert "no specular" in no_caustic_reason(PhotonSource(floor_only).until_stored(10).stats)


def test_a_light_whose_photons_escape_past_the_mirror_says_so():
    """A mirror facing away from every receiver: the photons reach it and leave the scene."""
    mirror = SceneObject("mirror", horizontal(0.0, A_HALF, B_HALF), MirrorMaterial(REFL))
    floor = SceneObject("floor", horizontal(-1.0, 3.0, 3.0), GREY)  # under the mirror only
    scene = make_scene([mirror, floor], [PointLight((0.0, D_LIGHT, 0.0), (1.0, 1.0, 1.0))])
    res = PhotonSource(scene).until_stored(100, max_emitted=20_000)
    assert len(res) == 0 and res.stats["escaped"] > 0
    assert re.fullmatch(r"no caustic photon stored of 20,000 shot toward the mirrors "
                        r"\['mirror'\] \(.*escaped [\d,]+.*\)", no_caustic_reason(res.stats))


def test_spot_light_aimed_away_from_mirror_is_an_error():
    light = SpotLight((0.0, D_LIGHT, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 1.0), 30.0)
    with pytest.raises(InputError, match=r"no light reaches a specular object.*cone_deg"):
        trace_caustic_photons(make_scene(mirror_and_ceiling(), [light]))


def test_cap_reached_with_few_photons_warns():
    scene = make_scene(mirror_and_ceiling(), [PointLight((0.0, D_LIGHT, 0.0), (1.0, 1.0, 1.0))])
    with pytest.warns(TracingWarning, match=r"only \d+ of n_stored_target=5,000"):
        res = trace_caustic_photons(scene, 5000, max_emitted=1000)
    assert res.emitted == 1000 and 0 < len(res) < 5000 and res.stats["stopped_by"] == "cap"


@pytest.mark.parametrize("kwargs, match", [
    ({"n_stored_target": 0}, r"n_stored_target=0 is out of range"),
    ({"seed": -1}, r"seed=-1 is out of range"),
    ({"batch_size": 0}, r"batch_size=0 is out of range"),
])
def test_bad_arguments_are_errors(kwargs, match):
    scene = make_scene(mirror_and_ceiling(), [PointLight((0.0, D_LIGHT, 0.0), (1.0, 1.0, 1.0))])
    with pytest.raises(InputError, match=match):
        trace_caustic_photons(scene, **kwargs)


def test_zero_max_bounces_is_an_error():
    scene = make_scene(mirror_and_ceiling(), [PointLight((0.0, D_LIGHT, 0.0), (1.0, 1.0, 1.0))])
    scene = duck_scene(scene, photons=SimpleNamespace(count=100, k=50, A=8, seed=1, max_bounces=0))
    with pytest.raises(InputError, match=r"max_bounces=0.*at least one mirror bounce"):
        trace_caustic_photons(scene)
