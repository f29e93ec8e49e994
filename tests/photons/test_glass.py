"""Glass: Fresnel and Snell arithmetic, total internal reflection, photon power in
expectation, the tracer (shared by the photon map and the light tracer) on analytic cases,
the loader's errors and the canonical glass scene."""

from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import context_or_skip

from blockhash.errors import InputError
from blockhash.photons.tracing import ABSORBED, ESCAPED, MAX_BOUNCES, STORED, trace_batch
from blockhash.scene import meshes
from blockhash.scene.loader import load_scene, parse_scene
from blockhash.scene.model import Camera, DielectricMaterial, PhongMaterial, Scene, SceneObject, SpotLight
from blockhash.scene.optics import fresnel, refract, scatter
from blockhash.scene.raycast import EmbreeGeometry

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

ROOT = Path(__file__).resolve().parents[2]


def normal_reflectance(n):
    return ((n - 1) / (n + 1)) ** 2


# --- Fresnel and Snell ------------------------------------------------------------------------

def test_fresnel_at_normal_incidence_brewster_and_grazing():
    n = 1.5
    assert fresnel(1.0, 1 / n) == pytest.approx(normal_reflectance(n), rel=1e-12)
    assert fresnel(1.0, n) == pytest.approx(normal_reflectance(n), rel=1e-12)  # from inside
    assert fresnel(0.0, 1 / n) == pytest.approx(1.0)
    # At Brewster's angle (tan = n) the p polarisation is not reflected: F = r_s^2 / 2.
    tb = np.arctan(n)
    tt = np.arcsin(np.sin(tb) / n)
    rs = (np.cos(tb) - n * np.cos(tt)) / (np.cos(tb) + n * np.cos(tt))
    assert fresnel(np.cos(tb), 1 / n) == pytest.approx(0.5 * rs ** 2, rel=1e-12)


def test_fresnel_matches_the_textbook_formula_at_every_angle():
    n1, n2 = 1.0, 1.33
    ti = np.linspace(0.0, np.pi / 2 - 1e-3, 50)
    tt = np.arcsin(n1 / n2 * np.sin(ti))
    rs = (n1 * np.cos(ti) - n2 * np.cos(tt)) / (n1 * np.cos(ti) + n2 * np.cos(tt))
    rp = (n2 * np.cos(ti) - n1 * np.cos(tt)) / (n2 * np.cos(ti) + n1 * np.cos(tt))
    np.testing.assert_allclose(fresnel(np.cos(ti), n1 / n2), 0.5 * (rs ** 2 + rp ** 2), rtol=1e-10)
    assert np.all(np.diff(fresnel(np.cos(ti), n1 / n2)) >= -1e-15)  # rises toward grazing


def test_total_internal_reflection_past_the_critical_angle():
    n = 1.5
    critical = np.arcsin(1 / n)
    inside = fresnel(np.cos([critical - 1e-3, critical + 1e-3, 1.2]), n)
    assert inside[0] < 1.0 and np.all(inside[1:] == 1.0)
    d = np.array([[np.sin(critical + 0.01), -np.cos(critical + 0.01), 0.0]])
    _, tir = refract(d, np.array([[0.0, 1.0, 0.0]]), np.array([n]))
    assert tir[0]
    # scatter always reflects there, whatever the uniform
    up = np.array([[0.0, 1.0, 0.0]])
    out, through, factor = scatter(d, up, up, np.array([False]), np.array([n]),
                                   np.ones((1, 3)), np.array([0.999]))
    assert not through[0] and np.allclose(out, d * [1, -1, 1]) and np.all(factor == 1)


def test_snell_bends_toward_the_normal_in_the_plane_of_incidence():
    rng = np.random.default_rng(0)
    for eta in (1 / 1.5, 1 / 1.33, 1.2):
        d = rng.normal(size=(200, 3))
        d[:, 1] = -np.abs(d[:, 1]) - 0.3
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        n = np.tile([0.0, 1.0, 0.0], (200, 1))
        t, tir = refract(d, n, np.full(200, eta))
        ok = ~tir
        sin_i = np.linalg.norm(np.cross(d, n), axis=1)
        sin_t = np.linalg.norm(np.cross(t, n), axis=1)
        np.testing.assert_allclose(sin_t[ok], eta * sin_i[ok], rtol=1e-9, atol=1e-12)
        assert np.all(t[ok, 1] < 0)  # through the surface
        # coplanar: t lies in the plane of d and n
        np.testing.assert_allclose(np.einsum("ij,ij->i", t[ok], np.cross(d[ok], n[ok])), 0,
                                   atol=1e-12)
        assert np.array_equal(tir, eta * sin_i >= 1.0)


def test_a_photons_power_is_kept_in_expectation_and_no_photon_is_split():
    rng = np.random.default_rng(1)
    m = 200_000
    cos_i = 0.6
    d = np.tile([np.sqrt(1 - cos_i ** 2), -cos_i, 0.0], (m, 1))
    up = np.tile([0.0, 1.0, 0.0], (m, 1))
    tint = np.array([0.9, 0.5, 1.0])
    out, through, factor = scatter(d, up, up, np.ones(m, bool), np.full(m, 1.5),
                                   np.tile(tint, (m, 1)), rng.random(m))
    F = fresnel(cos_i, 1 / 1.5)
    assert out.shape == (m, 3) and through.mean() == pytest.approx(1 - F, abs=4e-3)
    # Expected outgoing power per unit in: F (reflected) + (1 - F) tint (transmitted).
    np.testing.assert_allclose(factor.mean(axis=0), F + (1 - F) * tint, atol=4e-3)
    np.testing.assert_allclose(factor[~through], 1.0)


# --- the tracer on analytic cases --------------------------------------------------------------

def floor_object():
    return SceneObject(name="floor", mesh=meshes.rectangle(x=(-20, 20), z=(-20, 20), y=0.0),
                       material=PhongMaterial(kd=0.5, ks=0.0, n=1.0))


def glass(name, mesh, ior=1.5, tint=1.0):
    return SceneObject(name=name, mesh=mesh, material=DielectricMaterial(ior=ior, tint=tint))


def slab_mesh(thickness, y, side=8.0):
    """A box of the given thickness centred at height y, with flat normals (trimesh's box
    shares its corners, whose averaged normals would tilt every refraction)."""
    box = trimesh.creation.box(extents=(side, thickness, side),
                               transform=trimesh.transformations.translation_matrix((0, y, 0)))
    tri = np.asarray(box.triangles).reshape(-1, 3)
    faces = np.arange(len(tri)).reshape(-1, 3)
    return meshes.with_normals(tri, faces, np.repeat(box.face_normals, 3, axis=0))


def trace_down(objects, m, cone_deg, *, height=3.0, max_bounces=16, seed=3):
    """Photons from a spot light straight above the origin, through the objects, to the
    floor: the batch, and the photons' total starting weight."""
    geom = EmbreeGeometry(tuple(objects))
    rng = np.random.default_rng(seed)
    cos_c = np.cos(np.radians(cone_deg))
    ct = 1 - rng.random(m) * (1 - cos_c)
    st = np.sqrt(1 - ct ** 2)
    phi = 2 * np.pi * rng.random(m)
    dirs = np.stack([st * np.cos(phi), -ct, st * np.sin(phi)], axis=1)
    origins = np.tile([0.0, height, 0.0], (m, 1))
    weights = np.ones((m, 3))
    return trace_batch(geom, origins, dirs, weights, max_bounces, seed=seed, start=0), weights


@pytest.mark.slow
@pytest.mark.parametrize("tint", [1.0, 0.8])
def test_a_glass_slab_at_normal_incidence_transmits_the_multiple_reflection_sum(tint):
    """A slab between light and floor: the floor receives (1 - R)^2 t^2 / (1 - R^2) of the
    light at normal incidence (t the tint per crossing; internal reflections summed)."""
    n = 1.5
    slab = glass("slab", slab_mesh(0.2, 1.0), ior=n, tint=tint)
    m = 200_000
    batch, w = trace_down([floor_object(), slab], m, cone_deg=0.5)
    R = normal_reflectance(n)
    expect = (1 - R) ** 2 * tint ** 2 / (1 - R ** 2)
    got = batch.weights[:, 0].sum() / w[:, 0].sum()
    assert got == pytest.approx(expect, abs=3 * np.sqrt(expect * (1 - expect) / m) + 1e-3)
    fates = np.bincount(batch.fate, minlength=8)
    assert fates[STORED] + fates[ESCAPED] + fates[MAX_BOUNCES] == m  # nothing else happens
    assert fates[ABSORBED] == 0 and fates[MAX_BOUNCES] < 5
    assert batch.depth.min() == 2  # in and out at least


def test_a_ball_lens_focuses_parallel_light_at_n_r_over_2_n_minus_1():
    """Paraxial rays through a ball of radius r cross the axis n r / (2 (n - 1)) beyond its
    centre (the back focal point; spherical aberration is below 0.1 % at h <= r / 20)."""
    n, r, cy = 1.5, 0.5, 2.0
    ball = glass("ball", meshes.sphere(center=(0, cy, 0), radius=r, subdivisions=7), ior=n)
    geom = EmbreeGeometry((floor_object(), ball))
    h = np.linspace(0.005, 0.025, 200)  # impact parameters, in the x-y plane
    origins = np.stack([h, np.full_like(h, 5.0), np.zeros_like(h)], axis=1)
    dirs = np.tile([0.0, -1.0, 0.0], (len(h), 1))
    batch = trace_batch(geom, origins, dirs, np.ones((len(h), 3)), 8, seed=11)
    twice = batch.depth == 2  # straight through: refracted in and out, no internal reflection
    assert twice.sum() > 0.8 * len(h)
    p, d = batch.positions[twice], batch.directions[twice]
    t = -p[:, 0] / d[:, 0]  # back along the ray to x = 0, the axis
    crossing = p[:, 1] + t * d[:, 1]
    focus = cy - crossing
    assert np.median(focus) == pytest.approx(n * r / (2 * (n - 1)), rel=0.01)


def test_energy_is_conserved_over_the_floor_under_a_clear_ball():
    """Clear glass absorbs nothing: every photon's weight stays 1, and it ends on the floor
    or escapes upward, reflected."""
    ball = glass("ball", meshes.sphere(center=(0, 1.0, 0), radius=0.5))
    m = 50_000
    batch, _ = trace_down([floor_object(), ball], m, cone_deg=9.0)
    assert np.all(batch.weights == 1.0)
    fates = np.bincount(batch.fate, minlength=8)
    assert fates[ABSORBED] == 0 and fates[STORED] + fates[ESCAPED] + fates[MAX_BOUNCES] \
        + fates[2] == m
    assert fates[STORED] > 0.9 * m


def test_a_photons_path_does_not_depend_on_the_batch():
    ball = glass("ball", meshes.sphere(center=(0, 1.0, 0), radius=0.5, subdivisions=3))
    geom = EmbreeGeometry((floor_object(), ball))
    rng = np.random.default_rng(2)
    d = np.column_stack([rng.normal(0, 0.1, 400), -np.ones(400), rng.normal(0, 0.1, 400)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.tile([0.0, 3.0, 0.0], (400, 1))
    whole = trace_batch(geom, o, d, np.ones((400, 3)), 8, seed=5, start=0)
    half = trace_batch(geom, o[200:], d[200:], np.ones((200, 3)), 8, seed=5, start=200)
    keep = whole.stored >= 200
    np.testing.assert_array_equal(whole.positions[keep], half.positions)


# --- the scene model and the loader -------------------------------------------------------------

GLASS_SCENE = (ROOT / "scenes" / "glass.toml").read_text()


@pytest.mark.parametrize("edit, match", [
    ('ior = 1.5', r"materials\.glass\.ior: missing required key"),
    ('ior = 1.0', r"materials\.glass\.ior: expected a number in \(1, 4\]; got 1\.0"),
    ('ior = 4.5', r"materials\.glass\.ior: expected a number in \(1, 4\]"),
    ('ior = "glass"', r"materials\.glass\.ior: expected a number; got 'glass'"),
    ('ior = 1.5\ntint = 1.2', r"materials\.glass\.tint: expected a number in \[0, 1\]"),
    ('ior = 1.5\ntint = [0.9, 0.9]', r"materials\.glass\.tint: expected"),
    ('ior = 1.5\nreflectance = 0.9', r"materials\.glass\.reflectance: unknown key"),
])
def test_the_loader_names_bad_dielectric_values(edit, match):
    text = GLASS_SCENE.replace("ior = 1.5", edit if edit != "ior = 1.5" else "")
    with pytest.raises(InputError, match=match):
        parse_scene(text, path="glass.toml")


def test_a_scene_with_glass_follows_8_specular_events_unless_told():
    scene = load_scene(ROOT / "scenes" / "glass.toml")
    assert scene.photons.max_bounces == 8 and scene.specular_objects[0].name == "ball"
    told = parse_scene(GLASS_SCENE + "\n[photons]\nmax_bounces = 3\n")
    assert told.photons.max_bounces == 3
    assert "dielectric, ior 1.5" in scene.summary()


def test_the_canonical_glass_scene_has_the_normative_values():
    s = load_scene(ROOT / "scenes" / "glass.toml")
    c = s.camera
    assert (list(c.eye), list(c.target), list(c.up), c.fov_y_deg, c.width, c.height) == \
        ([0.0, 1.6, 1.9], [0.0, 0.1, 0.2], [0.0, 1.0, 0.0], 38.0, 512, 512)
    floor, ball = s.objects
    assert np.allclose(floor.mesh.bounds, [[-1.5, 0, -1.5], [1.5, 0, 1.5]])
    assert (floor.material.kd[0], floor.material.ks[0], floor.material.n) == (0.6, 0.2, 20.0)
    assert ball.material.ior == 1.5 and np.all(ball.material.tint == 1.0)
    v = ball.mesh.vertices
    assert np.allclose(np.linalg.norm(v - [0, 0.3, 0], axis=1), 0.3)
    (light,) = s.lights
    assert list(light.position) == [0.0, 1.2, -1.5] and np.all(light.power == 100.0)


@pytest.mark.slow
def test_the_glass_ball_renders_with_its_caustic_in_its_shadow():
    context_or_skip("egl")
    from blockhash.passes.pipeline import render_scene

    scene = load_scene(ROOT / "scenes" / "glass.toml")
    r = render_scene(scene, photons=40_000, size=(64, 64), spp=4)
    caustic = r.caustic[..., 0]
    assert caustic.max() > 0
    row, col = np.unravel_index(np.argmax(caustic), caustic.shape)
    # In front of the ball (below its image, the ball sits in the upper middle) and central.
    assert row > 32 and abs(col - 32) < 8
    # The ball's pixels see the floor and its caustic through the glass: not black.
    assert r.direct[20:28, 28:36].mean() > 0


@pytest.mark.slow
def test_every_method_renders_glass_and_the_exact_one_agrees_with_the_cpu(tmp_path):
    context_or_skip("egl")
    from blockhash.evaluate.testing import assert_images_close
    from blockhash.passes.pipeline import render_scene
    from blockhash.studies.measure import flux_ratio

    scene = load_scene(ROOT / "scenes" / "glass.toml")
    from blockhash.photons.tracing import trace_caustic_photons
    pm = trace_caustic_photons(scene, 8000, seed=1)
    bh, exact, cpu = (render_scene(scene, photon_map=pm, size=(24, 24), spp=4, method=m)
                      for m in ("auto", "kdtree", "cpu"))  # the default and its CPU reference
    assert_images_close(bh.caustic, cpu.caustic, max_rel_rms=1e-4, out_dir=tmp_path)
    everywhere = np.ones((24, 24), bool)
    assert flux_ratio(bh.caustic, exact.caustic, everywhere) == pytest.approx(1.0, abs=0.05)


@pytest.mark.slow
def test_the_light_tracer_sees_a_point_light_through_a_glass_slab():
    """The light tracer through glass, against the analytic floor radiance under a slab:
    a spot light straight down through a slab of thickness t and index n onto a Lambertian
    floor seen from below the slab.  At the floor point under the light the irradiance is
    T I / h'^2, with T = (1 - R)^2 / (1 - R^2) (normal incidence, internal reflections
    summed) and h' = h - t (1 - 1/n) (the slab moves the light's image closer, paraxially);
    the radiance is kd E / pi."""
    from blockhash.reference.lighttrace import light_trace

    n, t, h, kd, power, cone = 1.5, 0.2, 3.0, 0.5, 10.0, 10.0
    slab = glass("slab", slab_mesh(t, 1.5), ior=n)
    floor = SceneObject(name="floor", mesh=meshes.rectangle(x=(-4, 4), z=(-4, 4)),
                        material=PhongMaterial(kd=kd, ks=0.0, n=1.0))
    light = SpotLight(position=[0, h, 0], direction=[0, -1, 0], power=power, cone_deg=cone)
    camera = Camera(eye=[0, 0.8, 0], target=[0, 0, 0], up=[0, 0, -1], fov_y_deg=4.0,
                    width=8, height=8)
    scene = Scene(camera=camera, lights=(light,), objects=(floor, slab))
    img = light_trace(scene, 4_000_000, seed=7)
    R = normal_reflectance(n)
    intensity = power / (2 * np.pi * (1 - np.cos(np.radians(cone))))
    expect = kd / np.pi * (1 - R) ** 2 / (1 - R ** 2) * intensity / (h - t * (1 - 1 / n)) ** 2
    centre = img.radiance[2:6, 2:6, 0]
    se = np.sqrt((img.stderr[2:6, 2:6, 0] ** 2).sum()) / centre.size
    assert img.visible.all()
    assert centre.mean() == pytest.approx(expect, abs=4 * se + 0.01 * expect)


def test_a_scene_built_in_code_with_glass_follows_8_events_too():
    ball = glass("ball", meshes.sphere(center=(0, 1.0, 0), radius=0.5, subdivisions=2))
    camera = Camera(eye=[0, 1, 3], target=[0, 0, 0], up=[0, 1, 0], fov_y_deg=40, width=8,
                    height=8)
    light = SpotLight(position=[0, 3, 0], direction=[0, -1, 0], power=1.0, cone_deg=20.0)
    assert Scene(camera=camera, lights=(light,), objects=(floor_object(), ball)).photons \
        .max_bounces == 8
    assert Scene(camera=camera, lights=(light,), objects=(floor_object(),)).photons \
        .max_bounces == 4
