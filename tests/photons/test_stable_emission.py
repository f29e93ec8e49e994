"""The emitter's stable placement (common random numbers for frames whose lights move): photons
of a dead projection-map cell placed by their own hashed sequence of cells, uniform over the
live cells on the host and on the Dr.Jit device, and moved between frames only when their own
cells change; the cones' frames turn with their axes."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.errors import InputError
from blockhash.photons.directions import REFERENCE, frames, orthonormal_basis
from blockhash.photons.emission import MAP_CELLS, STABLE_TRIES, tried_cell
from blockhash.photons.tracing import PhotonSource

SCENES = Path(__file__).resolve().parents[2] / "scenes"
PHOTONS = 300_000


def _source():
    return PhotonSource(blockhash.load_scene(SCENES / "ring.toml"), device="host")


def _with_map(source, live):
    source.emitter.cones = tuple(replace(c, live=live) for c in source.emitter.cones)
    return source


def _directions(source, where: str):
    """The unit directions of photons 0 .. PHOTONS - 1 of seed 7, emitted on ``where``."""
    em = source.emitter
    if where == "host":
        return em.sample(em.uniforms(7, 0, PHOTONS))[1]
    from blockhash.device.caustic import photon_streams
    from blockhash.device.choice import resolve
    from blockhash.device.emission import DeviceEmitter

    try:
        device = resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")
    mi, dr = device.modules()
    dev = DeviceEmitter(em, source.lights, source.scene.bounds, device)
    d = dev.sample(photon_streams(mi, dr, 7, 0, PHOTONS))[1]
    return np.asarray(d, dtype=np.float64).T  # Dr.Jit's (3, n)


def _mask(fraction: float, seed: int = 3) -> np.ndarray:
    return np.random.default_rng(seed).random((MAP_CELLS, MAP_CELLS)) < fraction


@pytest.mark.parametrize("where", ["host", "device"])
@pytest.mark.parametrize("fraction", [0.3, 0.02])
def test_the_emitter_fills_the_live_cells_uniformly(where, fraction):
    """Every photon lands in a live cell, each live cell equally often (chi-square within five
    of its standard deviations): at 2% live, a quarter of the dead-cell photons find no live
    cell in their tries and the rank among the live cells places them."""
    live = _mask(fraction)
    source = _with_map(_source(), live)
    cone = source.emitter.cones[0]
    cells = cone.cells_of(_directions(source, where))
    inside = live.reshape(-1)[cells]
    assert inside.mean() > 0.999  # float32 rounding may cross a cell's border on the device
    counts = np.bincount(cells[inside], minlength=MAP_CELLS ** 2)[live.reshape(-1)]
    expected = inside.sum() / live.sum()
    chi2 = ((counts - expected) ** 2 / expected).sum()
    dof = live.sum() - 1
    assert abs(chi2 - dof) < 5 * np.sqrt(2 * dof), (chi2, dof)


@pytest.mark.parametrize("where", ["host", "device"])
def test_a_photon_moves_only_when_its_own_cells_change(where):
    """One live cell dies and one dead cell comes alive: about the photons of those two cells'
    share move (the rank rule alone, which numbers the live cells, would move most dead-cell
    photons: every one ranked after the first changed cell)."""
    before = _mask(0.3)
    after = before.copy()
    on, off = np.argwhere(before), np.argwhere(~before)
    after[tuple(on[0])] = False
    after[tuple(off[-1])] = True
    a = _directions(_with_map(_source(), before), where)
    b = _directions(_with_map(_source(), after), where)
    moved = np.mean((a != b).any(axis=1))
    share = 1.0 / before.sum()
    assert 0.5 * share < moved < 8 * share, (moved, share)


def test_the_hash_is_one_code_for_numpy_and_the_device():
    """tried_cell on numpy uint32 and on Dr.Jit's UInt32 give the same cells."""
    from blockhash.device.choice import resolve

    try:
        mi, dr = resolve("cpu").modules()
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")
    seed = np.random.default_rng(1).integers(0, 2 ** 32, 10_000, dtype=np.uint64).astype(np.uint32)
    for t in (0, 1, STABLE_TRIES - 1):
        host = tried_cell(seed, t)
        dev = np.asarray(tried_cell(mi.UInt32(seed), mi.UInt32(t), u32=int))
        assert np.array_equal(host, dev)
        assert host.max() < MAP_CELLS ** 2


def test_a_cones_frame_turns_with_its_axis():
    """Axes along a circle through z = 0 (where a frame built on the sign of z turns half a
    circle) and over the poles: every frame right-handed and orthonormal, and consecutive
    frames apart by about the axes' own step; only near the reference does the frame turn fast."""
    s = np.linspace(0.0, 2.0 * np.pi, 3601)
    for axes in (np.stack([np.cos(s), 0.3 * np.ones_like(s), np.sin(s)], axis=1),
                 np.stack([np.cos(s), np.sin(s), 0.0 * s], axis=1),
                 np.stack([0.0 * s, np.cos(s), np.sin(s)], axis=1)):
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        t1, t2 = frames(axes)
        assert np.allclose(np.einsum("ij,ij->i", t1, axes), 0, atol=1e-12)
        assert np.allclose(np.linalg.norm(t1, axis=1), 1) and np.allclose(np.linalg.norm(t2, axis=1), 1)
        assert np.allclose(np.cross(t1, t2), axes, atol=1e-12)
        step = np.linalg.norm(np.diff(axes, axis=0), axis=1).max()
        assert np.linalg.norm(np.diff(t1, axis=0), axis=1).max() < 4 * step
    one = orthonormal_basis(np.array([0.0, 0.0, 1.0]))
    assert np.allclose(np.cross(*one), [0, 0, 1])
    near = orthonormal_basis(REFERENCE)  # the pole: the second reference
    assert np.allclose(np.cross(*near), REFERENCE)


def test_the_device_builds_the_hosts_frames():
    """An area light's per-photon frames on the device (cone_frame) are the host's (frames),
    in float32, near the reference's pole too."""
    from blockhash.device.choice import resolve
    from blockhash.device.emission import cone_frame

    try:
        mi, dr = resolve("cpu").modules()
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")
    axes = np.random.default_rng(4).normal(size=(2000, 3))
    axes[:3] = [REFERENCE, -REFERENCE, [0.0, -1.0, 0.0]]
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    want = frames(axes)
    got = cone_frame(mi, dr, mi.Vector3f(*axes.T.astype(np.float32)))
    for g, w in zip(got, want):
        np.testing.assert_allclose(np.asarray(g).T, w, atol=2e-5)
