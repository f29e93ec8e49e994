"""The cover gather's compiled build (blockhash/index/lookups/cover_build.py) gives, bit for bit,
what a plain numpy statement of each step gives: the records' octaves and window keys, and
the gather's records, whose windows hold the records in key order."""

import numpy as np
import pytest
from conftest import photon_set

from blockhash.frame.photon_radius import exact_radii2
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.lookups.cover import (
    CoverGather,
    axis_order,
    cover_margin,
    octave_fine,
    octave_halves,
    octave_sides,
)
from blockhash.index.lookups.cover_build import record_keys, window_entries
from blockhash.index.lookups.cover_keys import window_key64
from blockhash.index.records.octahedral import octahedral_tables


def unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def numpy_keys(index, slot_r2, kept, sides, fines, axis):
    step, margin = float(np.asarray(index.quantizer.step, np.float64).max()), cover_margin(index.quantizer)
    need = 2.0 * (np.sqrt(slot_r2[kept]) / step * (1.0 + 2.0**-20) + margin)
    o = np.minimum(np.searchsorted(sides, need, side="left"), len(sides) - 1)
    codes = index.records.records[kept][:, list(axis_order(axis))].astype(np.int64)
    return o, window_key64.py_func(o, codes[:, 0] // sides[o], codes[:, 1] // sides[o],
                                   codes[:, 2] // fines[o])


@pytest.mark.parametrize("fine", [1, 4])
def test_each_step_equals_its_numpy_statement(distribution, fine):
    pos = photon_set(distribution, 20000, seed=3)
    rng = np.random.default_rng(5)
    index = BlockHashIndex(pos, k=20, directions=unit(rng.normal(size=(len(pos), 3))),
                           normals=unit(rng.normal(size=(len(pos), 3))),
                           powers=rng.random((len(pos), 3)), tables=False)
    r2 = exact_radii2(index, 20)
    r2[::97] = np.inf  # photons left out (a pixel splat's)
    sides = octave_sides(2)
    fines = octave_fine(octave_halves(sides), fine)
    slot_r2 = r2[index.order]
    kept = np.flatnonzero(np.isfinite(slot_r2))
    for axis in range(3):
        want = numpy_keys(index, slot_r2, kept, sides, fines, axis)
        got = record_keys(index.records.records, kept, slot_r2, sides, fines,
                          np.array(axis_order(axis)), float(index.quantizer.step.max()),
                          cover_margin(index.quantizer))
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])

    gather = CoverGather.build(index, r2, fine=fine)
    key = window_key64.py_func(gather.octave, *(
        np.asarray(index.records.records[np.argsort(index.order)[gather.photon]][:, a], np.int64)
        // d for a, d in zip(axis_order(gather.axis), (gather.sides[gather.octave],
                                                       gather.sides[gather.octave],
                                                       gather.fines[gather.octave]))))
    assert np.all(key[1:] >= key[:-1])  # records in key order
    entries, max_count = window_entries(key, fine, len(sides))
    np.testing.assert_array_equal(gather.max_count, max_count)
    assert gather.windows == len(entries)

    rows = np.argsort(index.order)[gather.photon]  # each record's row of the index
    rec = index.records.records[rows]
    toward, normal = octahedral_tables()
    np.testing.assert_array_equal(gather.records[:, :3],
                                  index.quantizer.decode(rec[:, :3]).view(np.uint32))
    np.testing.assert_array_equal(gather.records[:, 3],
                                  slot_r2[rows].astype(np.float32).view(np.uint32))
    np.testing.assert_array_equal(gather.records[:, 4], toward[rec[:, 3] & 0xFFFF])
    np.testing.assert_array_equal(gather.records[:, 5], normal[rec[:, 3] >> 16])
    np.testing.assert_array_equal(gather.records[:, 6:8], rec[:, 4:6])


def test_no_window_of_an_empty_key_list():
    entries, max_count = window_entries(np.zeros(0, dtype=np.uint64), 4, 3)
    assert entries.shape == (0, 4) and not max_count.any()
