"""The environment map's sampling on the device (blockhash/device/environment.py) against the
host's tables, on a large map whose dim cells each hold less than float32's step near 1 (the
device picks a row, then a cell in the row: short tables, each cell's share kept): the density
it reports is the host's for the direction it drew, its radiance the host's, and the estimate
of the map's light unbiased, the dim part's and the whole's."""

from __future__ import annotations

import numpy as np
import pytest

from blockhash.device.choice import resolve
from blockhash.errors import InputError
from blockhash.scene.environment_light import EnvironmentLight


@pytest.fixture
def device():
    try:
        return resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")


def test_a_large_map_keeps_its_dim_cells_on_the_device(device):
    from blockhash.device.environment import DeviceEnvironment

    h, w = 513, 1024  # 524,288 cells
    img = np.full((h, w, 3), 1e-3)
    img[100:104, 200:204] = 2e3  # a sun with about 99% of the light
    light = EnvironmentLight(img)
    dim = light.cell_pmf[light.cell_pmf < light.cell_pmf.max() * 1e-3]
    assert dim.max() < 2.0 ** -24  # each below a float32 cdf's step near 1
    env = DeviceEnvironment(light, device)
    mi, dr = env.mi, env.dr
    n = 1 << 20
    u = np.random.default_rng(3).random((3, n)).astype(np.float32)
    on = dr.full(mi.Bool, True, n)
    toward, pdf = env.sample(*(mi.Float(c) for c in u), on)
    value = env.emitted(toward, on)
    toward = np.asarray(toward, dtype=np.float64).reshape(3, -1).T
    pdf = np.asarray(pdf, dtype=np.float64)
    value = np.asarray(value, dtype=np.float64).reshape(3, -1).T
    # float32 directions: across the sun's edge (2000 beside 0.001) a lookup moves steeply
    close = np.isclose(value, light.emitted(toward), rtol=1e-3, atol=1e-6).all(axis=1)
    assert close.mean() > 0.99
    agree = np.isclose(pdf, light.pdf(toward), rtol=1e-3)
    assert agree.mean() > 0.99  # but where a float32 direction rounds across a cell's border
    f = value[:, 0] / pdf
    sunlit = value[:, 0] > 1.0
    rest = np.where(sunlit, 0.0, f)
    exact_rest = 4 * np.pi * 1e-3 * (1 - 16 * 2 / (h * w))  # nearly the whole sphere at 1e-3
    assert abs(rest.mean() / exact_rest - 1) < 0.05, rest.mean() / exact_rest
    assert abs(f.mean() / light.integral[0] - 1) < 0.02


def test_a_spots_projected_texture_is_the_hosts_on_the_device(device):
    """The device's spot weight toward random directions in the cone (its falloff and its
    projected texture) is the host's ``falloff`` times ``texture_factor``, direction by
    direction (an asymmetric texture: a turn or a flip of the projection would show)."""
    from blockhash.device.light_tables import LightTables
    from blockhash.scene.lights import SpotLight
    from blockhash.scene.texture import Texture

    z = np.array([0.3, -0.9, 0.2])
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    img = np.random.default_rng(5).random((6, 9, 3)) * 3.0
    spot = SpotLight(position=[0.0, 2.0, 0.0], direction=z, power=[10.0, 10.0, 10.0],
                     cone_deg=30.0, beam_deg=20.0, texture=Texture(img, bounded=False),
                     frame=np.column_stack([x, np.cross(z, x), z]))
    tables = LightTables([spot], np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]]), device)
    mi, dr = tables.mi, tables.dr
    d = z + np.random.default_rng(6).normal(scale=0.35, size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    n = len(d)
    w = tables.spot_weight(dr.zeros(mi.UInt32, n), mi.Vector3f(*d.T.astype(np.float32)),
                           mi.Color3f(1.0, 1.0, 1.0) + dr.zeros(mi.Color3f, n),
                           dr.full(mi.Bool, True, n))
    ours = np.asarray(w, dtype=np.float64).reshape(3, -1).T
    cos = d @ z
    want = spot.falloff(cos)[:, None] * spot.texture_factor(d)
    inside = cos > np.cos(np.radians(30.0)) + 1e-4
    assert inside.mean() > 0.3
    close = np.isclose(ours[inside], want[inside], rtol=1e-3, atol=1e-4).all(axis=1)
    assert close.mean() > 0.995
    assert np.allclose(ours[cos < np.cos(np.radians(30.0)) - 1e-4], 0.0)
