"""What a worker process keeps for the renders it serves: each render's
:class:`~.task.RenderSetup`, built once from the render's spec (scene, settings, traced map;
sent as data, pickled) and found again by the spec's digest, and the process's identity
(blockhash version, source digest, GL backend) that a driver checks before it hands out a pass.

:func:`start` and :func:`run` serve a local process pool (:class:`~.executors.LocalWorkers`);
:func:`run_spec`, :func:`host` and :func:`identity` a Dask worker (:mod:`.dask_cluster`).  Every pass of a
process runs on one thread of its own (:func:`on_pass_thread`): a GL context is current on
one thread, and a Dask worker may run tasks on any of its threads.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import threading
from concurrent.futures import ThreadPoolExecutor

#: Setups of the renders this process has served, by spec digest (the last few).
_SETUPS: dict[str, object] = {}
#: Setups kept per process: a worker serving many renders keeps only the latest.
KEEP = 2
#: The spec of the local pool's render (:func:`start`).
_SPEC: dict = {}
_THREAD: list = []
_LOCK = threading.Lock()


def pack(spec) -> tuple[str, bytes]:
    """(digest, pickled spec): what travels to workers once per render."""
    data = pickle.dumps(spec, protocol=pickle.HIGHEST_PROTOCOL)
    return hashlib.sha256(data).hexdigest()[:16], data


def spec_file(packed: tuple[str, bytes]) -> tuple[str, str]:
    """(digest, path of a temporary file holding the pickled spec): what a local pool's
    workers are started with.  Not the spec itself: a spawned process reads its start
    arguments only after importing its parent's main module, and a worker that dies there
    (an unguarded script) would leave its parent blocked writing a spec larger than a pipe
    holds (multiprocessing closes the pipe's read end only after the write)."""
    import tempfile

    digest, data = packed
    with tempfile.NamedTemporaryFile(prefix=f"blockhash-spec-{digest}-", suffix=".pickle",
                                     delete=False) as f:
        f.write(data)
    return digest, f.name


def setup_for(digest: str, data: bytes | None = None):
    """The setup of the spec with ``digest`` in this process, built from ``data`` on first use."""
    from blockhash.passes.task import RenderSetup

    if digest not in _SETUPS:
        if data is None:
            raise KeyError(f"this process has no render {digest}")
        scene, settings, traced = pickle.loads(data)
        while len(_SETUPS) >= KEEP:
            _SETUPS.pop(next(iter(_SETUPS)))
        _SETUPS[digest] = RenderSetup(scene, settings, traced)
    return _SETUPS[digest]


def on_pass_thread(fn, *args):
    """``fn(*args)`` on this process's pass thread (one GL context, current on one thread)."""
    with _LOCK:
        if not _THREAD:
            _THREAD.append(ThreadPoolExecutor(1, thread_name_prefix="blockhash-pass",
                                              initializer=_pass_thread_start))
    return _THREAD[0].submit(fn, *args).result()


def share_cores(threads: int) -> None:
    """Let this process use ``threads`` threads for llvmpipe and numba (the machine's cores
    split among its workers); before the GL context is made.  numba's count is per thread:
    the pass thread takes it when it starts (:func:`_pass_thread_start`)."""
    os.environ.setdefault("LP_NUM_THREADS", str(threads))
    _SPEC["threads"] = threads


def _pass_thread_start() -> None:
    threads = _SPEC.get("threads")
    if threads is not None:
        from numba import config, set_num_threads

        set_num_threads(min(threads, config.NUMBA_NUM_THREADS))


def start(spec: tuple[str, str], threads: int, reports=None) -> None:
    """A local pool's initializer: the render's spec (digest, file: :func:`spec_file`) and
    this process's share of the cores;
    ``reports`` (a queue) hears ``(pid, None)`` once this process has started, or ``(pid,
    error)`` where its start raised.  Ctrl-C is the driver's to handle (it writes the image so
    far and stops the workers)."""
    import signal

    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        share_cores(threads)
        digest, path = spec
        with open(path, "rb") as f:
            _SPEC["digest"], _SPEC["data"] = digest, f.read()
    except Exception as exc:
        if reports is not None:
            reports.put((os.getpid(), f"{type(exc).__name__}: {exc}"))
        raise
    if reports is not None:
        reports.put((os.getpid(), None))


#: A spawned process exits with this code where its main module starts a render on import.
MAIN_GUARD_EXIT = 78


def refuse_while_importing_main() -> None:
    """End this process (exit :data:`MAIN_GUARD_EXIT`) if it is a spawned worker still
    importing its parent's main module: a script without an ``if __name__ == "__main__":``
    guard renders on import, and every worker would start a render (and workers) of its own.
    The render that started the workers names the cause (:class:`.executors.WorkersFailed`)."""
    import multiprocessing
    import sys

    if getattr(multiprocessing.current_process(), "_inheriting", False):  # as multiprocessing checks
        main = getattr(sys.modules.get("__mp_main__"), "__file__", None) or "its main module"
        print(f"blockhash: worker process {os.getpid()} stops: importing {main} started a render "
              "(the script has no if __name__ == \"__main__\": guard)", file=sys.stderr)
        raise SystemExit(MAIN_GUARD_EXIT)


def run(p: int, emitted):
    """Pass ``p`` of the local pool's render (:func:`start`), without what stays here."""
    return run_spec(_SPEC["digest"], _SPEC["data"], p, emitted)


def run_spec(digest: str, data: bytes, p: int, emitted):
    """Pass ``p`` of the render of spec ``(digest, data)``: its portable contribution, with
    the warnings it raised recorded for the driver to repeat."""
    return on_pass_thread(_run, digest, data, p, emitted)


def _run(digest, data, p, emitted):
    import warnings

    from blockhash.passes.task import run_pass

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        contribution = run_pass(setup_for(digest, data), p, emitted).portable()
    contribution.info["warnings"] = [(w.category, str(w.message)) for w in caught]
    where = host()
    contribution.info["ran_in"] = f"rendered by worker process {where['pid']} on {where['host']}"
    return contribution


def cores() -> int:
    """The cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def host() -> dict:
    """This process's machine (name and cores) and pid."""
    import socket

    return {"host": socket.gethostname(), "cores": cores(), "pid": os.getpid()}


def identity(backend=None, threads: int | None = None) -> dict:
    """This process's blockhash version, source digest and GL (the backend that made a
    context, or why none could be made), on the pass thread; ``threads``: its share of the
    machine's cores (:func:`share_cores`), set first."""
    if threads is not None:
        share_cores(threads)
    return on_pass_thread(_identity, backend)


def _identity(backend):
    import blockhash
    from blockhash.code_version import source_digest

    try:
        from blockhash.gl.context import get_context

        ctx = get_context(backend)
        gl = f"{ctx.extra['backend']}: {ctx.info['GL_RENDERER']}"
    except Exception as exc:  # noqa: BLE001 - reported to the driver, which refuses the worker
        gl = None
        why = str(exc)
    else:
        why = None
    return {"version": blockhash.__version__, "digest": source_digest(), "gl": gl,
            "gl_error": why, **host()}
