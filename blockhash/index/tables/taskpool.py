"""Run a tree of tasks on threads, the largest waiting task first.

A task may hand back more tasks (the two halves of a node it cut).  Each thread takes the
largest task waiting when it is free, so the large ones start early and the small ones
fill the end, and the threads finish close together.  Tasks run compiled code that
releases the GIL (numba ``nogil``), so the threads run on separate cores.
"""

from __future__ import annotations

import heapq
import itertools
import os
import threading
from concurrent.futures import ThreadPoolExecutor


def run_largest_first(tasks, run, size, workers: int | None = None) -> None:
    """Call ``run(task)`` for every task in ``tasks`` and every task that a call returns
    (``run`` returns an iterable of new tasks), largest ``size(task)`` first, on ``workers``
    threads (default: one per core).  The first exception stops the tasks not yet begun
    and is raised here."""
    heap = []
    order = itertools.count()  # equal sizes: first come, first run
    cond = threading.Condition()
    running = 0
    failed = []

    def push(task):
        heapq.heappush(heap, (-size(task), next(order), task))

    def worker():
        nonlocal running
        while True:
            with cond:
                while not heap and running and not failed:
                    cond.wait()
                if failed or not heap:
                    cond.notify_all()
                    return
                task = heapq.heappop(heap)[2]
                running += 1
            try:
                more = list(run(task))
            except BaseException as exc:  # noqa: BLE001 -- raised again by the caller
                more = []
                with cond:
                    failed.append(exc)
            with cond:
                for t in more:
                    push(t)
                running -= 1
                cond.notify_all()

    for t in tasks:
        push(t)
    workers = max(1, workers or os.cpu_count() or 1)
    if workers == 1:
        worker()
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            for f in [pool.submit(worker) for _ in range(workers)]:
                f.result()
    if failed:
        raise failed[0]
