"""Where a render's passes run: in this process (:class:`InProcess`, the default), in local
worker processes (:class:`LocalWorkers`), or on an existing Dask cluster
(:class:`~.dask_cluster.DaskCluster`, the ``blockhash[distributed]`` extra).

Each is a small frozen description (it travels in :class:`~.plan.RenderPlan`' ``executor``);
:meth:`open` starts it for one render and gives a :class:`Session`:

- ``submit(p, emitted)`` hands out pass p (``emitted``: the photons every pass after the
  first emits; None for pass 0);
- ``results()`` waits until at least one pass in flight ends and yields each ended one as
  ``(p, contribution)``; a pass that raised ends the render with :class:`PassFailed`;
- ``in_flight``, ``slots`` (passes worth keeping in flight) and ``workers``;
- ``close()`` cancels what is in flight.

A worker process builds the render's setup once (:mod:`.worker`) from the scene sent as data,
and reuses it, its GL context and its compiled programs for every pass it runs.  A worker that
dies costs the passes it held: they are handed out again, so no pass is lost or counted twice.
"""

from __future__ import annotations

from dataclasses import dataclass

from blockhash.errors import BlockHashError, InputError
from blockhash.passes import worker
from blockhash.passes.task import run_pass, trace_pass
from blockhash.passes.worker import cores

#: A pass whose worker died this many times ends the render (it is not the worker's fault).
MAX_WORKER_DEATHS = 3


class PassFailed(BlockHashError, RuntimeError):
    """A pass raised: the message names the pass and where it ran; the cause is chained."""

    def __init__(self, pass_index: int, where: str, cause: BaseException):
        super().__init__(f"pass {pass_index} failed {where}: {type(cause).__name__}: {cause}")
        self.pass_index, self.where, self.cause = pass_index, where, cause


def worker_count(value) -> int:
    """``value`` as a count of local worker processes: an int >= 1, or 'auto' (one per core)."""
    if value == "auto":
        return cores()
    count = value
    if isinstance(value, str):
        try:
            count = int(value)
        except ValueError:
            count = None
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise InputError.about("{workers}{value}: local worker processes are a count >= 1 or "
                               "'auto' (one per core, {cores} here); leave it out to render in "
                               "this process", value=value, cores=cores())
    return count


@dataclass(frozen=True)
class InProcess:
    """Every pass in this process, one after another (no extra dependency); with ``overlap``,
    the next pass's photons are traced on a second thread while this pass runs (embree and
    numba's kernels release the GIL, and the GL pass waits on llvmpipe's threads)."""

    overlap: bool = True
    workers: int = 1

    def open(self, renderer) -> "Session":
        return _InProcessSession(renderer, self.overlap)

    def describe(self) -> str:
        return "in this process"


@dataclass(frozen=True)
class LocalWorkers:
    """``count`` worker processes on this machine (``'auto'``: one per core); each keeps one
    pass in flight and splits the cores with the others (llvmpipe's and numba's threads)."""

    count: int | str = "auto"

    def __post_init__(self):
        object.__setattr__(self, "count", worker_count(self.count))

    @property
    def workers(self) -> int:
        return self.count

    def open(self, renderer) -> "Session":
        return _PoolSession(renderer, self.count)

    def describe(self) -> str:
        return f"{self.count} local worker process{'es' if self.count > 1 else ''}"


class Session:
    """One render's use of an executor (module docstring)."""

    workers = 1
    slots = 1

    def __init__(self):
        self.flight: dict[int, object] = {}

    @property
    def in_flight(self) -> int:
        return len(self.flight)

    def close(self) -> None:
        self.flight.clear()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class _InProcessSession(Session):
    def __init__(self, renderer, overlap: bool):
        super().__init__()
        self.renderer = renderer
        self.slots = 2 if overlap else 1  # the next pass known while this one runs
        self.ahead = None  # (pass, future of its trace_pass)
        self.tracer = None
        if overlap:
            from concurrent.futures import ThreadPoolExecutor

            self.tracer = ThreadPoolExecutor(1, thread_name_prefix="blockhash-trace")

    def submit(self, p: int, emitted) -> None:
        self.flight[p] = emitted

    def results(self):
        p = min(self.flight)
        emitted = self.flight[p]
        self.renderer.index = self.renderer.radii = None  # the last pass's go first
        setup = self.renderer.setup
        ahead = self.ahead[1].result() if self.ahead and self.ahead[0] == p else None
        self.ahead = None
        later = [q for q in self.flight if q > p]
        if self.tracer is not None and later and self.flight[min(later)] is not None:
            q = min(later)
            self.ahead = (q, self.tracer.submit(_Ahead, setup, q, self.flight[q]))
        # run_pass holds the photons alone (they are freed once indexed, not kept here)
        contribution = run_pass(setup, p, emitted, traced=ahead.take() if ahead else None)
        del self.flight[p]
        yield p, contribution

    def close(self) -> None:
        super().close()
        if self.tracer is not None:
            self.tracer.shutdown(wait=True, cancel_futures=True)
        self.ahead = None


class _Ahead:
    """A pass's :func:`trace_pass`, run on the tracing thread, until :meth:`take` hands it
    over (and lets go of it)."""

    def __init__(self, setup, p: int, emitted):
        self.traced = trace_pass(setup, p, emitted)

    def take(self):
        traced, self.traced = self.traced, None
        return traced


class _PoolSession(Session):
    """Passes in a pool of spawned processes; a pool broken by a dying worker is replaced and
    its passes handed out again."""

    def __init__(self, renderer, count: int):
        super().__init__()
        self.workers = count
        self.slots = 2 * count  # each worker's next pass queued: none waits on the driver
        self.spec = worker.pack(renderer.spec)
        self.threads = max(1, cores() // count)
        self.deaths: dict[int, int] = {}
        self.pool = self._pool()

    def _pool(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        return ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"),
                                   initializer=worker.start, initargs=(self.spec, self.threads))

    def submit(self, p: int, emitted) -> None:
        future = self.pool.submit(worker.run, p, emitted)
        future.emitted = emitted
        self.flight[p] = future

    def results(self):
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        done, _ = wait(list(self.flight.values()), return_when=FIRST_COMPLETED)
        broken = []
        for p, future in sorted(self.flight.items()):
            if future not in done:
                continue
            try:
                contribution = future.result()
            except BrokenProcessPool:
                broken.append(p)
                continue
            except Exception as exc:  # noqa: BLE001 - any error of a pass ends the render
                raise PassFailed(p, "in a local worker process", exc) from exc
            del self.flight[p]
            yield p, contribution
        if broken:
            self._restart(broken)

    def _restart(self, broken) -> None:
        """A worker died: a new pool, and every pass the old one held handed out again."""
        for p in broken:
            self.deaths[p] = self.deaths.get(p, 0) + 1
            if self.deaths[p] >= MAX_WORKER_DEATHS:
                raise PassFailed(p, "in a local worker process", RuntimeError(
                    f"its worker process died {self.deaths[p]} times (killed, or out of "
                    "memory); lower the photons per pass or the workers"))
        self.pool.shutdown(wait=False, cancel_futures=True)
        self.pool = self._pool()
        again = {p: f.emitted for p, f in self.flight.items()}
        self.flight.clear()
        for p, emitted in sorted(again.items()):
            self.submit(p, emitted)

    def close(self) -> None:
        for future in self.flight.values():
            future.cancel()
        super().close()
        processes = list(getattr(self.pool, "_processes", {}).values())  # the pool's own
        self.pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:  # a pass still running is not wanted: stop it now
            process.terminate()
        for process in processes:
            process.join(5)
