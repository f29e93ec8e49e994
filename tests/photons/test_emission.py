"""The projection maps of the emission cones: photons only where a mirror is met first, the
caustic flux unchanged (the plain cones, which the light tracer samples, are the oracle)."""

from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.photons.emission import MAP_CELLS, Emitter, projection_map
from blockhash.photons.tracing import FATE_NAMES, PhotonSource

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def _flux(source, seeds, count):
    """(mean, standard error) of the stored flux over independent seeds."""
    vals = np.array([source.emit(count, seed=s).powers.sum(axis=0) for s in seeds])
    return vals.mean(axis=0), vals.std(axis=0, ddof=1) / np.sqrt(len(vals))


@pytest.mark.parametrize("name", ["ring", "venus"])
def test_the_map_keeps_the_caustic_flux_of_the_plain_cones(name):
    scene = blockhash.load_scene(SCENES / f"{name}.toml")
    mapped = PhotonSource(scene)
    plain = PhotonSource(scene)
    plain.emitter = Emitter(plain.lights, plain.specular)
    assert all(c.live is not None for c in mapped.emitter.cones)
    assert all(c.live is None for c in plain.emitter.cones)
    m, sm = _flux(mapped, range(1, 7), 60_000)
    p, sp = _flux(plain, range(11, 17), 60_000)
    z = (m - p) / np.sqrt(sm ** 2 + sp ** 2)
    assert np.all(np.abs(z) < 4.0), (m, p, z)


def test_the_map_traces_fewer_photons_that_miss_or_light_directly():
    """Venus: most photons of the plain cones meet the head and neck first; with the map,
    several times fewer are shot for the same stored photons (on the host, whose emitter the
    test replaces)."""
    scene = blockhash.load_scene(SCENES / "venus.toml")
    mapped = PhotonSource(scene, device="host").until_stored(20_000, seed=3)
    plain_source = PhotonSource(scene, device="host")
    plain_source.emitter = Emitter(plain_source.lights, plain_source.specular)
    plain = plain_source.until_stored(20_000, seed=3)
    assert plain.emitted > 3 * mapped.emitted
    fates = dict(zip(FATE_NAMES, (mapped.stats[k] for k in FATE_NAMES)))
    assert fates["direct_diffuse"] < 0.5 * mapped.emitted


def test_a_cell_is_live_around_every_pilot_ray_that_meets_a_mirror():
    """The map of a cone holds the cells whose pilot rays meet the mirror, grown by a cell:
    directions into the mirror sampled finely all fall in live cells."""
    scene = blockhash.load_scene(SCENES / "ring.toml")
    source = PhotonSource(scene)
    cone = source.emitter.cones[0]
    live = projection_map(cone, source.emitter.positions[cone.light], source.geometry)
    assert live.shape == (MAP_CELLS, MAP_CELLS) and 0.05 < live.mean() < 0.95
    rng = np.random.default_rng(5)
    u = rng.random((200_000, 4))
    plain = Emitter(source.lights, source.specular)
    origins, dirs, _, _ = plain.sample(u)
    hit, face, _, _ = source.geometry.intersect(origins + dirs * 1e-6, dirs)
    to_mirror = np.zeros(len(dirs), bool)
    to_mirror[np.flatnonzero(hit)] = source.geometry.is_specular[source.geometry.face_object[face]]
    cells = cone.cells_of(dirs[to_mirror])
    assert live.reshape(-1)[cells].all()
