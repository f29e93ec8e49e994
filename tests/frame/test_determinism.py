"""Determinism: the same scene, seed and parameters give bit-identical photon maps,
indices and images across runs, batch sizes and GL backends (docs/extremes.md)."""

import numpy as np
import pytest
from conftest import context_or_skip
from conftest import small_ring_scene as scene

from blockhash import BlockHashIndex
from blockhash.passes.pipeline import render_scene
from blockhash.photons.tracing import trace_caustic_photons

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

FIELDS = ("positions", "directions", "normals", "powers")


@pytest.fixture(scope="module")
def ring():
    return scene()


def test_photon_maps_are_identical_across_runs_and_batch_sizes(ring):
    a = trace_caustic_photons(ring, 3000, seed=7)
    b = trace_caustic_photons(ring, 3000, seed=7)
    c = trace_caustic_photons(ring, 3000, seed=7, batch_size=777)
    d = trace_caustic_photons(ring, 3000, seed=8)
    for f in FIELDS:
        assert getattr(a, f).tobytes() == getattr(b, f).tobytes() == getattr(c, f).tobytes(), f
    assert a.positions.tobytes() != d.positions.tobytes()


def test_indices_are_identical_across_builds_and_builders(ring):
    pm = trace_caustic_photons(ring, 3000, seed=7)
    kw = dict(k=8, A=4, directions=pm.directions, normals=pm.normals, powers=pm.powers)
    a = BlockHashIndex(pm.positions, **kw)
    b = BlockHashIndex(pm.positions.copy(), **kw)
    c = BlockHashIndex(pm.positions, builder="btree", **kw)
    for x in (b, c):
        assert a.block_words.tobytes() == x.block_words.tobytes()
        assert a.thresholds.tobytes() == x.thresholds.tobytes()
        assert a.tables.refs.tobytes() == x.tables.refs.tobytes()
    q = pm.positions[:200]
    assert all(np.array_equal(u, v) for u, v in zip(a.query(q), b.query(q)))


@pytest.mark.slow
def test_images_are_identical_across_runs_and_backends(ring):
    context_or_skip("egl")
    context_or_skip("osmesa")
    kw = dict(photons=2000, size=(12, 10), seed=3)
    egl = render_scene(ring, backend="egl", **kw)
    again = render_scene(ring, backend="egl", **kw)
    osmesa = render_scene(ring, backend="osmesa", **kw)
    for name, layer in egl.layers().items():
        assert layer.tobytes() == again.layers()[name].tobytes(), name
        assert layer.tobytes() == osmesa.layers()[name].tobytes(), name
    assert egl.caustic.max() > 0
