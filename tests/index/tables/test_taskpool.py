"""Tasks that spawn tasks run to the end on threads; the first failure is raised."""

import threading

import pytest

from blockhash.index.tables.taskpool import run_largest_first


@pytest.mark.parametrize("workers", [1, 2, 4])
def test_every_spawned_task_runs_once(workers):
    done = []
    lock = threading.Lock()

    def halve(task):
        with lock:
            done.append(task)
        lo, hi = task
        if hi - lo <= 3:
            return []
        mid = (lo + hi) // 2
        return [(lo, mid), (mid, hi)]

    run_largest_first([(0, 1000)], halve, lambda t: t[1] - t[0], workers=workers)
    assert len(done) == len(set(done))
    leaves = sorted(t for t in done if t[1] - t[0] <= 3)
    assert [lo for lo, _ in leaves[1:]] == [hi for _, hi in leaves[:-1]]  # they tile 0..1000
    assert leaves[0][0] == 0 and leaves[-1][1] == 1000
    assert len(done) == 2 * len(leaves) - 1


def test_largest_first_on_one_thread():
    order = []
    run_largest_first([3, 9, 1, 5], lambda t: order.append(t) or [], lambda t: t, workers=1)
    assert order == [9, 5, 3, 1]


@pytest.mark.parametrize("workers", [1, 2])
def test_a_failure_is_raised(workers):
    def run(task):
        if task == 7:
            raise ValueError("task 7")
        return [task + 1] if task < 20 else []

    with pytest.raises(ValueError, match="task 7"):
        run_largest_first([0], run, lambda t: -t, workers=workers)
