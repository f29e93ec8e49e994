"""The Hilbert cells lookup (blockhash/index/lookups/cells.py, cell_query.py, glsl/bh_cells.glsl)."""

import numpy as np
import pytest

from blockhash import BlockHashIndex
from blockhash.evaluate.metrics import exact_knn, false_negatives
from blockhash.evaluate.photon_maps import MAPS, queries
from blockhash.index.lookups.cells import LEVEL_MIN, LEVEL_TOP, build_cells, cell_lookup, cell_runs
from blockhash.index.lookups.cells_query import CELL_ROUNDS, SHELL_ORDER
from blockhash.index.records.fixedpoint import Quantizer


def _index(name="caustic", n=20_000, k=20, A=8, seed=0):
    pm = MAPS[name]
    pts = pm.photons(n, np.random.default_rng(seed))
    q = queries(pm, 1500, np.random.default_rng(seed + 1)).astype(np.float32)
    return BlockHashIndex(pts, k=k, A=A), q


def test_every_octree_cell_is_one_run_of_the_hilbert_order():
    index, _ = _index()
    codes = np.ascontiguousarray(index.records.records[:, :3])
    for level in (LEVEL_MIN, 8, 14, LEVEL_TOP):
        _, _, coords = cell_runs(codes, level)
        # one run per distinct cell: no cell is split along the curve
        assert len(coords) == len(np.unique(coords, axis=0))


def test_every_stored_cell_is_found_with_its_photons():
    index, _ = _index(n=5_000)
    codes = np.ascontiguousarray(index.records.records[:, :3])
    table = build_cells(codes, min_split=2)
    mask = np.uint32(table.buckets - 1)
    for level in (LEVEL_TOP, 16, 10):
        starts, counts, coords = cell_runs(codes, level)
        found = 0
        for s, c, xyz in zip(starts, counts, coords):
            first, n = cell_lookup(table.slots, mask, level, *(int(v) for v in xyz))
            if n:
                assert (first, n) == (s, c)
                found += 1
        assert found > 0
    # a cell outside every photon's run is not found
    far = codes.max(axis=0) >> np.uint32(11 + 10)
    assert cell_lookup(table.slots, mask, 10, int(far[0]) + 5, 0, 0)[1] == 0


def test_the_quantizer_has_one_step_on_every_axis():
    pts = np.random.default_rng(0).random((100, 3)) * np.array([3.0, 0.01, 1.0])
    q = Quantizer.for_points(pts)
    assert q.step[0] == q.step[1] == q.step[2]


def test_shell_order_visits_the_own_cell_then_faces_edges_corners():
    shell = [abs(j % 3 - 1) + abs(j // 3 % 3 - 1) + abs(j // 9 - 1) for j in SHELL_ORDER]
    assert SHELL_ORDER[0] == 13 and shell == sorted(shell) and sorted(SHELL_ORDER) == list(range(27))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["uniform", "plane", "tilted", "sphere"])
def test_cells_find_near_neighbours_and_tighten_with_A(name):
    index, q = _index(name, k=20)
    _, ei = exact_knn(index.positions, q, 20)
    fn = {}
    for A in (8, 64):
        _, i = index.query(q, A=A, lookup="cells")
        fn[A] = false_negatives(i, ei, len(index)).mean() / 20
        assert index.counters["query.rounds.max"] == CELL_ROUNDS
        assert index.counters["query.candidates.mean"] <= A * 20
    assert fn[64] <= fn[8] + 1e-9
    assert fn[8] < 0.06 and fn[64] < 0.01, fn


def test_cells_answer_like_ckdtree():
    index, q = _index(k=8)
    q[0] = np.nan
    d, i = index.query(q, lookup="cells")
    assert d.shape == (len(q), 8) and np.isinf(d[0]).all() and (i[0] == len(index)).all()
    ok = np.isfinite(d[1:])
    assert (np.diff(d[1:], axis=1)[ok[:, 1:]] >= 0).all()  # nearest first
    # the distances are those of the photons returned
    r = 5
    assert np.allclose(d[r], np.linalg.norm(index.positions[i[r]] - q[r], axis=1), rtol=1e-5)


def test_an_unknown_lookup_is_refused_by_name():
    index, q = _index(n=2_000, k=4)
    with pytest.raises(Exception, match="lookup='nearest' is not known"):
        index.query(q, lookup="nearest")
