"""The Dr.Jit indirect photons (blockhash.device.indirect) against the host's
(blockhash.photons.indirect): the power each receiver stores and the paths' counts agree
within the noise, for the scenes whose diffuse surfaces light one another (an area light in a
closed box, point lights over a floor and walls), and the photons are the same in any batch."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from blockhash.device.choice import resolve
from blockhash.errors import InputError
from blockhash.photons.indirect import IndirectSource
from blockhash.scene.loader import load_scene
from blockhash.scene.raycast import EmbreeGeometry

SCENES = Path(__file__).resolve().parents[2] / "scenes"


@pytest.fixture(autouse=True)
def cpu_device():
    try:
        return resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")


def per_object(scene, photons):
    n = photons.emitted
    w = photons.powers.astype(np.float64) * n
    total = np.zeros((len(scene.objects), 3))
    second = np.zeros((len(scene.objects), 3))
    np.add.at(total, photons.objects, w / n)
    np.add.at(second, photons.objects, (w / n) ** 2)
    return total, np.sqrt(np.maximum(second - total ** 2 / n, 0.0))


@pytest.mark.parametrize("name", ["cbox", "corner", "venus", "corner under a sky",
                                  "cbox under a textured lamp", "cbox of plastic"])
def test_the_kernels_indirect_photons_carry_the_hosts_power_to_every_receiver(name):
    if name.endswith("under a sky"):  # the synthetic environment map alone
        from environment_maps import sky

        scene = replace(load_scene(SCENES / f"{name.split()[0]}.toml"), lights=(sky(),))
    elif name.endswith("of plastic"):  # coats that reflect a share of each bounce, smooth
        from test_caustic_kernels import coated  # and (floor, back) rough

        scene = coated(coated(load_scene(SCENES / "cbox.toml")), ("floor", "back"), alpha=0.2)
    elif name.endswith("textured lamp"):
        from test_caustic_kernels import textured_lamp

        scene = textured_lamp(load_scene(SCENES / "cbox.toml"))
    else:
        scene = load_scene(SCENES / f"{name}.toml")
    geometry = EmbreeGeometry(tuple(scene.objects))
    host = IndirectSource(scene, geometry, device="host").emit(200_000, seed=5)
    kern = IndirectSource(scene, geometry, device="cpu").emit(200_000, seed=5)
    a, a_err = per_object(scene, host)
    b, b_err = per_object(scene, kern)
    err = np.sqrt(a_err ** 2 + b_err ** 2)
    lit = a.sum(axis=1) > 0.02 * a.sum()
    assert lit.any()
    for i in np.flatnonzero(lit):
        assert np.all(np.abs(a[i] - b[i]) < 4.5 * err[i] + 1e-3 * a[i]), (
            scene.objects[i].name, a[i], b[i], err[i])
    for key in ("escaped", "roulette", "rays_cast"):
        h, k = host.stats[key], kern.stats[key]
        assert abs(h - k) < 6 * np.sqrt(max(h, 1)) + 1e-3 * h, (key, h, k)
    assert abs(len(host) - len(kern)) < 6 * np.sqrt(len(host)) + 10
    for arr in (kern.positions, kern.directions, kern.normals, kern.powers):
        assert arr.dtype == np.float32 and np.isfinite(arr).all()


def test_the_kernels_indirect_photons_are_the_same_whatever_the_launch():
    scene = load_scene(SCENES / "cbox.toml")
    source = IndirectSource(scene, EmbreeGeometry(tuple(scene.objects)), device="cpu")
    whole = source.emit(30_000, seed=2, start=1 << 44)
    again = source.emit(30_000, seed=2, start=1 << 44)
    assert np.array_equal(whole.positions, again.positions)
    assert np.array_equal(whole.powers, again.powers)
    # split in two launches: the same photons (each launch orders its own by event)
    first = source.emit(10_000, seed=2, start=1 << 44)
    rest = source.emit(20_000, seed=2, start=(1 << 44) + 10_000)
    rows = lambda *maps: np.unique(np.concatenate(  # noqa: E731
        [np.concatenate([m.positions, m.powers * m.emitted], axis=1) for m in maps]), axis=0)
    assert np.allclose(rows(whole), rows(first, rest), rtol=1e-6, atol=0)
    other = source.emit(30_000, seed=3, start=1 << 44)
    assert not np.array_equal(other.positions[:50], whole.positions[:50])


def test_a_launch_that_overflows_its_buffers_runs_again_with_the_same_photons():
    scene = load_scene(SCENES / "cbox.toml")
    geometry = EmbreeGeometry(tuple(scene.objects))
    roomy = IndirectSource(scene, geometry, device="cpu")
    roomy.kernels.stores_per_photon = 2.0
    tight = IndirectSource(scene, geometry, device="cpu")
    tight.kernels.stores_per_photon = 0.0  # room for 1,024: the first launch overflows
    a = roomy.emit(20_000, seed=4)
    b = tight.emit(20_000, seed=4)
    assert len(a) > 1024 and tight.kernels.stores_per_photon > 0.01
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.powers, b.powers)
    assert a.stats["rays_cast"] == b.stats["rays_cast"]
