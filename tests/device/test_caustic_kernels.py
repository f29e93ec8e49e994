"""The Dr.Jit caustic kernels (blockhash.device) against their oracle, the host's numba and
embree tracer (blockhash.photons.paths): for every kind of light, mirrors and glass, the power
each receiver stores and the photons' fates agree within the noise; the kernels' photons are
the same whatever the batch, the launch or the process."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import roughened

from blockhash.device.choice import resolve
from blockhash.errors import InputError
from blockhash.photons.tracing import FATE_NAMES, PhotonSource
from blockhash.scene.loader import load_scene, parse_scene
from blockhash.scene.model import SpotLight

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def _cpu_or_skip():
    try:
        return resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")


pytestmark = pytest.mark.usefixtures("cpu_device")


@pytest.fixture
def cpu_device():
    return _cpu_or_skip()


def small(name: str):
    text = (SCENES / f"{name}.toml").read_text()
    text = re.sub(r"(?m)^(radius = [0-9.]+)\n(?!subdivisions)", r"\1\nsubdivisions = 3\n", text)
    return parse_scene(text, path=SCENES / f"{name}.toml")


def per_object(scene, photons):
    """(objects, 3) stored power and its standard error over the photons emitted."""
    n = photons.emitted
    w = photons.powers.astype(np.float64) * n  # each photon's weight
    total = np.zeros((len(scene.objects), 3))
    second = np.zeros((len(scene.objects), 3))
    np.add.at(total, photons.objects, w / n)
    np.add.at(second, photons.objects, (w / n) ** 2)
    return total, np.sqrt(np.maximum(second - total ** 2 / n, 0.0))


def falloff_spot(scene):
    """``scene`` with its first point light a spot light with a falloff (beam inside the
    cone) aimed at the first specular object."""
    light = scene.lights[0]
    target = next(o for o in scene.objects if o.is_specular)
    aim = np.asarray(target.mesh.bounds, dtype=np.float64).mean(axis=0) - light.position
    spot = SpotLight(position=light.position, power=light.power, direction=aim / np.linalg.norm(aim),
                     cone_deg=25.0, beam_deg=10.0)
    return replace(scene, lights=(spot,) + tuple(scene.lights[1:]))


def under_sky(scene):
    """``scene`` lit by the synthetic environment map alone."""
    from environment_maps import sky

    return replace(scene, lights=(sky(0.05),))


def textured_spot(scene):
    """``scene`` under :func:`falloff_spot` with a texture projected across its cone (a
    stripe of red, one of blue, the rest grey)."""
    from blockhash.scene.texture import Texture

    spot = falloff_spot(scene).lights[0]
    z = np.asarray(spot.direction)
    x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    img = np.full((8, 8, 3), 0.5)
    img[:, :2], img[:, 6:] = [1.0, 0.1, 0.1], [0.1, 0.1, 1.0]
    spot = replace(spot, texture=Texture(img, wrap="clamp", bounded=False),
                   frame=np.column_stack([x, np.cross(z, x), z]))
    return replace(scene, lights=(spot,) + tuple(scene.lights[1:]))


def textured_lamp(scene):
    """``scene`` with its area light's radiance a texture (a red half, a blue half) over the
    lamp's (x, z)."""
    from blockhash.scene.lights import AreaLight
    from blockhash.scene.texture import Texture

    lights = []
    for light in scene.lights:
        if isinstance(light, AreaLight):
            v = np.asarray(light.mesh.vertices)
            uv = (v[:, [0, 2]] - v[:, [0, 2]].min(axis=0)) / np.ptp(v[:, [0, 2]], axis=0)
            img = np.zeros((4, 4, 3))
            img[:, :2], img[:, 2:] = [30.0, 3.0, 3.0], [3.0, 3.0, 30.0]
            texture = Texture(img, wrap="clamp", filter="nearest", bounded=False)
            light = replace(light, radiance=texture.mean, texture=texture, uv=uv)
        lights.append(light)
    return replace(scene, lights=tuple(lights))


def coated(scene, names=None, coat: float = 1.6, alpha: float = 0.0, distribution="beckmann"):
    """``scene`` with its diffuse receivers (or those ``names``) under a coat
    (:mod:`blockhash.scene.coat`), smooth or of roughness ``alpha``: plastic, whose coats
    reflect a share of the light."""
    from blockhash.scene.coat import largest_albedo
    from blockhash.scene.materials import PhongMaterial

    top = largest_albedo(coat, alpha, distribution)

    def plastic(m):
        return PhongMaterial(kd=np.minimum(m.kd, top), ks=0.0, n=0.0, sided=m.sided, coat=coat,
                             coat_reflectance=np.array([1.0, 0.8, 0.6]), alpha=alpha,
                             distribution=distribution)

    objects = tuple(replace(o, material=plastic(o.material))
                    if isinstance(o.material, PhongMaterial) and (names is None or o.name in names)
                    else o for o in scene.objects)
    return replace(scene, objects=objects)


CASES = {
    "ring (point light, mirror)": lambda: small("ring"),
    "glass (point light, Fresnel choices)": lambda: small("glass"),
    "cbox (area light)": lambda: small("cbox"),
    "sun (directional light, glass)": lambda: small("sun"),
    "venus (two point lights)": lambda: small("venus"),
    "ring under a spot with a falloff": lambda: falloff_spot(small("ring")),
    "sun under an environment map (glass)": lambda: under_sky(small("sun")),
    "ring under a spot with a projected texture": lambda: textured_spot(small("ring")),
    "cbox under a lamp of textured radiance": lambda: textured_lamp(small("cbox")),
    "ring of rough gold (Beckmann)": lambda: roughened(small("ring"), 0.2, "beckmann"),
    "frosted glass (GGX)": lambda: roughened(small("glass"), 0.15, "ggx"),
    "ring on a plastic floor": lambda: coated(small("ring")),
    "cbox of plastic (area light)": lambda: coated(small("cbox")),
    "ring on a rough plastic floor (GGX)": lambda: coated(small("ring"), alpha=0.15,
                                                          distribution="ggx"),
}


@pytest.mark.parametrize("case", ["ring of rough gold (Beckmann)", "frosted glass (GGX)",
                                  "ring on a rough plastic floor (GGX)"])
def test_the_kernels_spread_a_rough_surfaces_caustic_as_the_host_does(case):
    scene = CASES[case]()
    host = PhotonSource(scene, device="host").emit(200_000, seed=7)
    kern = PhotonSource(scene, device="cpu").emit(200_000, seed=7)
    for photons in (host, kern):
        assert np.isfinite(photons.powers).all()

    def moments(photons):
        w = photons.powers.astype(np.float64).sum(axis=1)
        p = photons.positions.astype(np.float64)
        mean = (p * w[:, None]).sum(axis=0) / w.sum()
        return mean, np.sqrt((((p - mean) ** 2) * w[:, None]).sum(axis=0) / w.sum())

    (ma, sa), (mb, sb) = moments(host), moments(kern)
    size = float(np.ptp(np.concatenate([o.mesh.vertices for o in scene.objects]), axis=0).max())
    assert np.all(np.abs(ma - mb) < 0.01 * size), (ma, mb)
    assert np.all(np.abs(sa - sb) < 0.02 * sa + 0.002 * size), (sa, sb)


@pytest.mark.parametrize("case", list(CASES))
def test_the_kernels_store_the_power_the_host_tracer_stores_on_every_receiver(case):
    scene = CASES[case]()
    host = PhotonSource(scene, device="host").emit(200_000, seed=7)
    kern = PhotonSource(scene, device="cpu").emit(200_000, seed=7)
    a, a_err = per_object(scene, host)
    b, b_err = per_object(scene, kern)
    err = np.sqrt(a_err ** 2 + b_err ** 2)
    lit = a.sum(axis=1) > 0.01 * a.sum()
    assert lit.any()
    for i in np.flatnonzero(lit):
        assert np.all(np.abs(a[i] - b[i]) < 4.5 * err[i] + 1e-3 * a[i]), (
            scene.objects[i].name, a[i], b[i], err[i])
    assert not np.any(b[~lit] > 0.02 * a.sum()), "no power where the host stores almost none"
    # the fates of the photons shot, each within the binomial noise
    for name in FATE_NAMES:
        p, q = host.stats[name] / host.emitted, kern.stats[name] / kern.emitted
        sd = np.sqrt(max(p * (1 - p), 1.0 / host.emitted) / host.emitted * 2)
        assert abs(p - q) < 5 * sd + 1e-4, (name, host.stats[name], kern.stats[name])
    assert host.stats["emitted_per_light"] != () and len(kern.stats["emitted_per_light"]) == len(scene.lights)
    for arr in (kern.positions, kern.directions, kern.normals, kern.powers):
        assert arr.dtype == np.float32 and np.isfinite(arr).all()
    # directions arrive into the surface, normals lie on the side the photon came from
    assert np.mean(np.einsum("ij,ij->i", kern.directions, kern.normals) < 0) > 0.99
    assert np.allclose(np.linalg.norm(kern.directions, axis=1), 1.0, atol=1e-5)


def test_the_kernels_stop_at_the_stored_count_as_the_host_does():
    scene = small("ring")
    host = PhotonSource(scene, device="host").until_stored(30_000, seed=3)
    kern = PhotonSource(scene, device="cpu").until_stored(30_000, seed=3)
    assert len(host) == len(kern) == 30_000
    assert kern.stats["stopped_by"] == "target"
    # the (n+1)-th stored photon ends the run: emitted within the noise of the host's
    rate = len(host) / host.emitted
    assert abs(kern.emitted - host.emitted) < 6 * np.sqrt(30_000 * (1 - rate)) / rate


def test_the_kernels_photons_are_the_same_whatever_the_batch_and_the_launch():
    scene = small("glass")  # glass: the Fresnel choices draw from the streams too
    source = PhotonSource(scene, device="cpu")
    whole = source.emit(50_000, seed=11, start=1 << 44)
    first = source.emit(20_000, seed=11, start=1 << 44)
    rest = source.emit(30_000, seed=11, start=(1 << 44) + 20_000)
    for name in ("positions", "directions", "normals"):
        joined = np.concatenate([getattr(first, name), getattr(rest, name)])
        assert np.array_equal(getattr(whole, name), joined), name
    weights = np.concatenate([first.powers * first.emitted, rest.powers * rest.emitted])
    assert np.allclose(whole.powers * whole.emitted, weights, rtol=1e-6, atol=0)
    again = source.until_stored(5_000, seed=11, batch_size=997)
    once = source.until_stored(5_000, seed=11)
    assert again.emitted == once.emitted and np.array_equal(again.positions, once.positions)
    other = source.emit(20_000, seed=12, start=1 << 44)
    assert not np.array_equal(other.positions[:100], first.positions[:100])


CHILD = """
import sys, numpy as np
from blockhash.photons.tracing import PhotonSource
from blockhash.scene.loader import load_scene
p = PhotonSource(load_scene(sys.argv[2]), device="cpu").emit(20_000, seed=11, start=1 << 44)
np.save(sys.argv[1], np.concatenate([p.positions, p.powers], axis=1))
"""


def test_the_kernels_photons_are_the_same_in_another_process(tmp_path):
    out = tmp_path / "photons.npy"
    subprocess.run([sys.executable, "-c", CHILD, str(out), str(SCENES / "glass.toml")],
                   check=True, cwd=tmp_path, env={**os.environ, "BLOCKHASH_DEVICE": "host"},
                   timeout=300)
    p = PhotonSource(load_scene(SCENES / "glass.toml"), device="cpu").emit(
        20_000, seed=11, start=1 << 44)
    assert np.array_equal(np.load(out), np.concatenate([p.positions, p.powers], axis=1))


def test_a_one_sided_receiver_met_from_behind_absorbs_on_the_device_too():
    scene = mirror_under_a_ceiling()
    kern = PhotonSource(scene, device="cpu").emit(20_000, seed=1)
    host = PhotonSource(scene, device="host").emit(20_000, seed=1)
    assert len(kern) == len(host) == 0
    assert kern.stats["absorbed"] > 0.5 * kern.emitted and host.stats["absorbed"] > 0.5 * host.emitted


def mirror_under_a_ceiling():
    """A point light between a mirror facing up and a one-sided ceiling whose front faces
    up, away from the mirror's light (tests/photons/test_one_sided_photons.py's scene)."""
    import trimesh

    from blockhash.scene.model import (
        Camera,
        MirrorMaterial,
        PhongMaterial,
        PhotonSettings,
        PointLight,
        Scene,
        SceneObject,
    )

    def panel(y, half, facing):
        v = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]])
        faces = np.array([[0, 2, 1], [0, 3, 2]]) if facing > 0 else np.array([[0, 1, 2], [0, 2, 3]])
        return trimesh.Trimesh(v, faces, vertex_normals=np.tile([0.0, facing, 0.0], (4, 1)),
                               process=False)

    mirror = SceneObject("mirror", panel(0.0, 0.4, 1.0), MirrorMaterial(0.9))
    ceiling = SceneObject("ceiling", panel(2.0, 3.0, 1.0),
                          PhongMaterial(kd=0.5, ks=0.0, n=0.0, sided="one"))
    camera = Camera(eye=(0.0, 0.3, 1.5), target=(0.0, 2.0, 0.0), up=(0.0, 0.0, -1.0),
                    fov_y_deg=60.0, width=24, height=24)
    return Scene(camera=camera, lights=(PointLight((0.2, 1.0, 0.0), 10.0),),
                 objects=(mirror, ceiling), photons=PhotonSettings(count=2000, seed=3))
