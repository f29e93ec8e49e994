"""Area and directional lights' caustic photons (blockhash.photons.light_targets) against an
emission that aims at nothing: an area light's photons cosine-distributed over its whole
hemisphere, a directional light's uniform over a disc wider than the scene.  Both are
unbiased without any knowledge of the mirrors, so the aimed photons' stored power must agree
with theirs within the noise, per receiving object."""

from __future__ import annotations

import re
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.photons.directions import frames
from blockhash.photons.emission import photon_uniforms
from blockhash.photons.paths import trace_batch
from blockhash.photons.tracing import PhotonSource
from blockhash.scene.loader import load_scene, parse_scene
from blockhash.scene.model import AreaLight, DirectionalLight
from blockhash.scene.raycast import EmbreeGeometry

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def small(name: str):
    """A shipped scene with coarse spheres (fast to trace)."""
    text = (SCENES / f"{name}.toml").read_text()
    return parse_scene(coarse(text), path=SCENES / f"{name}.toml")


def coarse(text: str) -> str:
    return re.sub(r"(radius = [0-9.]+)\n", r"\1\nsubdivisions = 3\n", text)


def stored_power(scene, batch_weights_objects):
    out = np.zeros((len(scene.objects), 3))
    for w, obj in batch_weights_objects:
        np.add.at(out, obj, w)
    return out


def naive_area(scene, light: AreaLight, n: int, seed: int):
    """Photons of ``light`` cosine-distributed over its front hemisphere: each carries
    power / n; the stored power per object and its per-photon second moment."""
    geom = EmbreeGeometry(tuple(scene.objects))
    u = photon_uniforms(seed, 0, n)
    areas = light.face_areas
    f = np.minimum(np.searchsorted(np.cumsum(areas) / areas.sum(), u[:, 0], side="right"),
                   len(areas) - 1)
    s = np.sqrt(u[:, 1])
    b0, b2 = 1.0 - s, s * u[:, 2]
    tri = light.triangles[f]
    y = b0[:, None] * tri[:, 0] + (1 - b0 - b2)[:, None] * tri[:, 1] + b2[:, None] * tri[:, 2]
    nrm = light.face_normals[f]
    v = photon_uniforms(seed + 1, 0, n)
    r, phi = np.sqrt(v[:, 0]), 2 * np.pi * v[:, 1]
    t1, t2 = frames(nrm)
    d = (r * np.cos(phi))[:, None] * t1 + (r * np.sin(phi))[:, None] * t2 \
        + np.sqrt(np.maximum(1 - r * r, 0))[:, None] * nrm
    w = np.broadcast_to(light.power, (n, 3)).copy()
    b = trace_batch(geom, y, d, w, scene.photons.max_bounces, seed=seed, start=0)
    return b, n


def naive_directional(scene, light: DirectionalLight, n: int, seed: int):
    """Photons of ``light`` uniform over a disc across its direction that covers the whole
    scene, each E * disc area / n."""
    geom = EmbreeGeometry(tuple(scene.objects))
    lo, hi = scene.bounds
    center, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo)) * 1.01
    D = light.direction
    t1, t2 = frames(D[None, :])
    u = photon_uniforms(seed, 0, n)
    rho, phi = radius * np.sqrt(u[:, 0]), 2 * np.pi * u[:, 1]
    o = center - D * 2 * radius + (rho * np.cos(phi))[:, None] * t1 + (rho * np.sin(phi))[:, None] * t2
    w = np.broadcast_to(light.irradiance * np.pi * radius ** 2, (n, 3)).copy()
    b = trace_batch(geom, o, np.broadcast_to(D, (n, 3)).copy(), w, scene.photons.max_bounces,
                    seed=seed, start=0)
    return b, n


def per_object(scene, b, n):
    """(objects, 3) stored power and its standard error from a batch of ``n`` photons."""
    total = np.zeros((len(scene.objects), 3))
    second = np.zeros((len(scene.objects), 3))
    np.add.at(total, b.objects, b.weights / n)
    np.add.at(second, b.objects, (b.weights / n) ** 2)
    return total, np.sqrt(np.maximum(second - total ** 2 / n, 0.0))


@pytest.mark.parametrize("name, naive, n_naive", [("cbox", naive_area, 1_500_000),
                                                  ("sun", naive_directional, 1_500_000)])
def test_aimed_photons_carry_the_power_of_photons_aimed_at_nothing(name, naive, n_naive):
    scene = small(name)
    source = PhotonSource(scene)
    aimed = source.emit(300_000, seed=3)
    a, a_err = per_object(scene, SimpleBatch(aimed), aimed.emitted)
    b, n = naive(scene, scene.lights[0], n_naive, seed=11)
    c, c_err = per_object(scene, b, n)
    err = np.sqrt(a_err ** 2 + c_err ** 2)
    lit = c.sum(axis=1) > 0.02 * c.sum()
    assert lit.any(), "the caustic reaches a receiver"
    for i in np.flatnonzero(lit):
        assert np.all(np.abs(a[i] - c[i]) < 4 * err[i] + 1e-3 * c[i]), (
            scene.objects[i].name, a[i], c[i], err[i])
    # Aiming keeps most of the photons shot: the stored fraction is far above the naive one.
    assert len(aimed.positions) / aimed.emitted > 5 * len(b.stored) / n


class SimpleBatch:
    """A CausticPhotons seen as a batch of weights per photon (powers times emitted)."""

    def __init__(self, photons):
        self.objects = photons.objects
        self.weights = photons.powers * photons.emitted


def test_two_lights_of_different_kinds_add_up():
    """An area light and sunlight in one scene: the photons of a pass are shared by what each
    sends toward the glass, and the caustic is the sum of each light's alone."""
    sun = small("sun")
    lamp_text = (SCENES / "sun.toml").read_text().replace(
        "[[objects]]\nname = \"table\"",
        "[materials.lamp]\nkind = \"phong\"\nkd = 0.0\n\n[[objects]]\nname = \"lamp\"\n"
        "material = \"lamp\"\nemission = 40.0\nrotate_deg = [180.0, 0.0, 0.0]\n"
        "translate = [-0.2, 1.2, 0.3]\n[objects.shape]\nkind = \"rectangle\"\nx = [-0.1, 0.1]\n"
        "z = [-0.1, 0.1]\n\n[[objects]]\nname = \"table\"", 1)
    both = parse_scene(coarse(lamp_text), path=SCENES / "sun.toml")
    kinds = sorted(type(li).__name__ for li in both.lights)
    assert kinds == ["AreaLight", "DirectionalLight"]
    sun_only = replace(both, lights=tuple(li for li in both.lights if isinstance(li, DirectionalLight)))
    lamp_only = replace(both, lights=tuple(li for li in both.lights if isinstance(li, AreaLight)))
    flux = {}
    for key, scene in (("both", both), ("sun", sun_only), ("lamp", lamp_only)):
        p = PhotonSource(scene).emit(400_000, seed=5)
        err = np.sqrt(((p.powers) ** 2).sum(axis=0))
        flux[key] = (p.powers.sum(axis=0), err)
        if key == "both":
            per_light = p.stats["emitted_per_light"]
            assert all(c > 0 for c in per_light), per_light
    total = flux["sun"][0] + flux["lamp"][0]
    err = np.sqrt(flux["both"][1] ** 2 + flux["sun"][1] ** 2 + flux["lamp"][1] ** 2)
    assert np.all(np.abs(flux["both"][0] - total) < 4 * err), (flux, total)
    assert sun.lights[0].irradiance.tolist() == both.lights[0].irradiance.tolist()


def test_point_light_photons_are_unchanged_by_the_new_lights():
    """The point and spot lights' photons keep their streams: the ring's first photons are the
    same numbers whether or not the emitter knows area lights (no extra uniforms drawn)."""
    ring = load_scene(SCENES / "ring.toml")
    source = PhotonSource(ring)
    assert source.emitter.surfaces is None and not source.emitter.targets
    u = source.emitter.uniforms(1, 0, 8)
    assert isinstance(u, np.ndarray) and u.shape == (8, 4)
    np.testing.assert_array_equal(u, photon_uniforms(1, 0, 8))


# ----------------------------------------------------------------- bad input

CBOX = (SCENES / "cbox.toml").read_text()
SUN = (SCENES / "sun.toml").read_text()


@pytest.mark.parametrize("text, match", [
    (CBOX.replace("emission = [60.0, 51.0, 39.0]", "emission = [-1.0, 1.0, 1.0]"),
     r"objects\[5\]\.emission\[0\]: expected a number in \[0, inf\); got -1"),
    (CBOX.replace("emission = [60.0, 51.0, 39.0]", "emission = nan"),
     r"objects\[5\]\.emission: expected a finite number; got nan"),
    (CBOX.replace("emission = [60.0, 51.0, 39.0]", "emission = inf"),
     r"objects\[5\]\.emission: expected a finite number; got inf"),
    (CBOX.replace("emission = [60.0, 51.0, 39.0]", "emission = 0.0"),
     r"objects\[5\]\.emission: the light emits nothing.*leave emission out"),
    (CBOX.replace('x = [-0.2, 0.2]\nz = [-0.2, 0.2]', 'x = [-0.2, 0.2]\nz = [-0.2, 0.2]')
     .replace("translate = [0.0, 1.98, 0.0]", "translate = [0.0, 1.98, 0.0]\nscale = 1e-200"),
     r"objects\[5\].*zero area.*fix the mesh or its scale"),
    (CBOX.replace('name = "mirror_ball"\nmaterial = "mirror"',
                  'name = "mirror_ball"\nmaterial = "mirror"\nemission = 1.0'),
     r"objects\[6\]\.emission: object 'mirror_ball' has the 'mirror' material, a mirror: "
     r"blockhash's emitters are diffuse surfaces"),
    (CBOX.replace('name = "glass_ball"\nmaterial = "glass"', 'name = "glass_ball"\nmaterial = "glass"\nemission = 1.0'),
     r"objects\[7\]\.emission: .*a glass"),
    (SUN.replace("direction = [0.778, -0.574, -0.254]", "direction = [0.0, 0.0, 0.0]"),
     r"lights\[0\]\.direction: expected a non-zero direction"),
    (SUN.replace("irradiance = [3.0, 2.9, 2.7]", "irradiance = -3.0"),
     r"lights\[0\]\.irradiance: expected a number in \[0, inf\); got -3"),
    (SUN.replace("irradiance = [3.0, 2.9, 2.7]", "irradiance = [0.0, nan, 1.0]"),
     r"lights\[0\]\.irradiance\[1\]: expected a finite number; got nan"),
    (SUN.replace("irradiance = [3.0, 2.9, 2.7]", "irradiance = 0"),
     r"lights\[0\]\.irradiance: the light emits nothing"),
    (SUN.replace("irradiance = [3.0, 2.9, 2.7]", "irradiance = 3.0\npower = 1.0"),
     r"lights\[0\]\.power: unknown key; allowed keys here: kind, direction, irradiance"),
])
def test_bad_lights_name_the_light_the_value_and_the_way_out(text, match):
    with pytest.raises(InputError, match=r"^scenes/x\.toml: " + match):
        parse_scene(text, path="scenes/x.toml")


def test_area_light_objects_are_checked_in_python_too():
    scene = load_scene(SCENES / "cbox.toml")
    lamp = next(o for o in scene.objects if o.name == "light")
    ball = next(o for o in scene.objects if o.name == "mirror_ball")
    with pytest.raises(InputError, match=r"lights\[1\]: area light on object 'mirror_ball', a mirror"):
        replace(scene, lights=scene.lights + (AreaLight("mirror_ball", ball.mesh, 1.0),))
    with pytest.raises(InputError, match=r"lights\[1\]: area light on object 'nothing', which the "
                                         r"scene does not hold"):
        replace(scene, lights=scene.lights + (AreaLight("nothing", lamp.mesh, 1.0),))
    with pytest.raises(InputError, match=r"lights\[0\]: area light on object 'light' with a mesh "
                                         r"other than the object's"):
        replace(scene, lights=(AreaLight("light", lamp.mesh.copy(), 1.0),))


def test_an_area_light_facing_away_renders_direct_light_with_a_warning(tmp_path):
    """The lamp turned to face the ceiling: no photon can reach a sphere; the render goes on
    (direct light: none from a lamp facing away, but the lamp is seen from behind as black)
    and warns once with the reason, naming the specular objects."""
    from blockhash.passes.pipeline import render

    text = CBOX.replace('rotate_deg = [180.0, 0.0, 0.0]\ntranslate = [0.0, 1.98, 0.0]',
                        'translate = [0.0, 1.98, 0.0]')
    scene = parse_scene(text, path=SCENES / "cbox.toml").with_size(24, 24)
    with pytest.raises(InputError, match="no light reaches the specular objects"):
        from blockhash.photons.tracing import trace_caustic_photons
        trace_caustic_photons(scene, 1000)
    from blockhash.passes.plan import RenderPlan

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = render(scene, photons=1000, plan=RenderPlan(passes=1))
    msgs = [str(w.message) for w in caught if "direct light only" in str(w.message)]
    assert len(msgs) == 1 and "no light reaches the specular objects" in msgs[0], msgs
    assert "mirror_ball" in msgs[0] and "glass_ball" in msgs[0]
    assert float(np.abs(image.caustic).sum()) == 0.0
