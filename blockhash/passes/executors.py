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
A pool that keeps breaking ends the render instead (:class:`WorkersFailed`): a pass whose
worker died :data:`MAX_WORKER_DEATHS` times, or :data:`MAX_START_FAILURES` pools in a row whose
workers died before they started (at once, naming the missing ``if __name__ == "__main__":``
guard, when the workers died re-running an unguarded script).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from blockhash.errors import BlockHashError, InputError
from blockhash.passes import worker
from blockhash.passes.task import run_pass, trace_pass
from blockhash.passes.worker import cores

#: A pass whose worker died this many times ends the render (it is not the worker's fault).
MAX_WORKER_DEATHS = 3
#: Pools in a row whose workers died before they started end the render.
MAX_START_FAILURES = 3


class PassFailed(BlockHashError, RuntimeError):
    """A pass raised: the message names the pass and where it ran; the cause is chained.
    ``image``: the passes merged before it (:func:`blockhash.render` sets it)."""

    image = None

    def __init__(self, pass_index: int, where: str, cause: BaseException):
        super().__init__(f"pass {pass_index} failed {where}: {type(cause).__name__}: {cause}")
        self.pass_index, self.where, self.cause = pass_index, where, cause


class WorkersFailed(BlockHashError, RuntimeError):
    """Local worker processes kept dying: the message names why (the missing main guard, the
    workers' exit codes or the exception that stopped them).  ``image``: the passes merged
    before (:func:`blockhash.render` sets it)."""

    image = None


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
        self.spec = worker.spec_file(worker.pack(renderer.spec))  # (digest, path); removed on close
        self.threads = max(1, cores() // count)
        self.deaths: dict[int, int] = {}
        self.causes: dict[int, list] = {}  # pass -> the (exit code, start error)s of its deaths
        self.start_failures = 0  # pools in a row broken by workers that never started
        self.start_deaths: list = []  # their (exit code, start error)s
        import multiprocessing

        self.context = multiprocessing.get_context("spawn")
        self.reports = self.context.SimpleQueue()  # what each worker's start says (worker.start)
        self.started: dict[int, str | None] = {}  # pid -> None (started) or the start's error
        self.pool = self._pool()

    def _pool(self):
        from concurrent.futures import ProcessPoolExecutor

        return ProcessPoolExecutor(self.workers, mp_context=self.context, initializer=worker.start,
                                   initargs=(self.spec, self.threads, self.reports))

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

    def _dead(self) -> tuple[list[tuple[int, str]], list[tuple[int, str]]]:
        """The broken pool's dead workers as (those that never started, those that did), each
        (exit code, what its start reported)."""
        while not self.reports.empty():
            pid, error = self.reports.get()
            self.started[pid] = error
        never, did = [], []
        for process in list(getattr(self.pool, "_processes", {}).values()):
            process.join(5)  # the pool is broken: its workers are ending
            if process.exitcode is None:
                continue
            started = process.pid in self.started and self.started[process.pid] is None
            (did if started else never).append((process.exitcode, self.started.get(process.pid)))
        return never, did

    def _restart(self, broken) -> None:
        """A worker died: a new pool, and every pass the old one held handed out again; a pool
        that keeps breaking ends the render (:class:`WorkersFailed`)."""
        never, did = self._dead()
        if any(code == worker.MAIN_GUARD_EXIT for code, _ in never):
            raise WorkersFailed(main_guard_message())
        at_start = bool(never) and not did  # no worker of the pool started: no pass ran
        self.start_failures = self.start_failures + 1 if at_start else 0
        self.start_deaths = self.start_deaths + never if at_start else []
        if self.start_failures >= MAX_START_FAILURES:
            raise WorkersFailed(
                f"local worker processes died before they started, {self.start_failures} pools "
                f"in a row ({_exits(self.start_deaths)}); their tracebacks are on this "
                "process's standard error.  Render in this process (without local workers) to "
                "see the error directly")
        for p in [] if at_start else broken:
            self.deaths[p] = self.deaths.get(p, 0) + 1
            self.causes[p] = self.causes.get(p, []) + did + never
            if self.deaths[p] >= MAX_WORKER_DEATHS:
                raise PassFailed(p, "in a local worker process", RuntimeError(
                    f"its worker process died {self.deaths[p]} times ({_exits(self.causes[p])}; "
                    "killed, or out of memory); lower the photons per pass or the workers"))
        self.pool.shutdown(wait=False, cancel_futures=True)
        self.pool = self._pool()
        again = {p: f.emitted for p, f in self.flight.items()}
        self.flight.clear()
        for p, emitted in sorted(again.items()):
            self.submit(p, emitted)

    def close(self) -> None:
        for future in self.flight.values():
            future.cancel()
        self.reports.close()
        Path(self.spec[1]).unlink(missing_ok=True)
        super().close()
        processes = list(getattr(self.pool, "_processes", {}).values())  # the pool's own
        self.pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:  # a pass still running is not wanted: stop it now
            process.terminate()
        for process in processes:
            process.join(5)


def _exits(dead) -> str:
    """Dead workers' (exit code, start error) pairs in words, each once; without the SIGTERM
    a broken pool ends its other workers with, where another cause is there."""
    import signal

    causes = [(code, error) for code, error in dead if code != -signal.SIGTERM] or dead
    words = sorted({exit_reason(code) + (f": {error}" if error else "") for code, error in causes})
    return "; ".join(words) or "exit unknown"


def exit_reason(code: int) -> str:
    """A process's exit code in words: ``exit code 1``, ``killed by SIGKILL``."""
    if code < 0:
        import signal

        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def main_guard_message() -> str:
    """Why local workers cannot start from a script without a main guard, and the fix."""
    import sys

    main = getattr(sys.modules.get("__main__"), "__file__", None) or "the main module"
    return (f"local worker processes could not start: each worker imports {main} again (the "
            "'spawn' start method), and it starts a render when imported.  Put the script's "
            "rendering under a main guard:\n\n"
            "    if __name__ == \"__main__\":\n"
            "        image = blockhash.render(scene, plan=RenderPlan(executor=LocalWorkers(2)))\n\n"
            "(docs/workers.md, 'Local workers from a script')")
