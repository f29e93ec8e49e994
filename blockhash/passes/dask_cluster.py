"""Passes on an existing Dask cluster (``dask.distributed``, the ``blockhash[distributed]``
extra), reached by its scheduler's address.

The cluster is started the way Dask documents it: ``dask scheduler`` on one machine,
``dask worker tcp://SCHEDULER:8786 --nthreads 1`` on each (one worker process per core or
GPU; a worker's passes run on one thread of its own whatever ``--nthreads`` says), or
dask-jobqueue on a batch system, or ``distributed.LocalCluster`` in Python.  blockhash starts
and manages no machine.

Before the first pass, every worker is asked for its machine, then for its blockhash version,
source digest and GL context (:func:`.worker.identity`), given its share of its machine's cores
for llvmpipe's and numba's threads (unless its environment sets ``LP_NUM_THREADS``); a worker
that differs from this process or has no GL is refused, by name.  The render's spec (scene,
settings) is scattered to the workers once (again, with the passes that needed it, if every
worker holding it dies); a pass is one task, ``retries=0`` so that a pass that raises ends
the render, while a pass whose worker dies is run again elsewhere by the scheduler (Dask's
``allowed-failures``).
"""

from __future__ import annotations

from dataclasses import dataclass

from blockhash.errors import InputError
from blockhash.passes.executors import PassFailed, Session

#: Seconds to wait for the scheduler to answer.
CONNECT_TIMEOUT = 10
HOW_TO_START = ("start one with `dask scheduler` and `dask worker tcp://HOST:8786 --nthreads 1` "
                "on each machine (pip install 'blockhash[distributed]'), or leave the address "
                "out to render in this process")


@dataclass(frozen=True)
class DaskCluster:
    """An existing Dask cluster, by its scheduler's ``address`` (``tcp://HOST:PORT``)."""

    address: str

    def __post_init__(self):
        if not isinstance(self.address, str) or "://" not in self.address and ":" not in self.address:
            raise InputError(f"scheduler={self.address!r}: a Dask scheduler's address is "
                             f"tcp://HOST:PORT; {HOW_TO_START}")

    @property
    def workers(self) -> int:
        return 0  # known once connected

    def open(self, renderer) -> Session:
        return _DaskSession(renderer, self.address)

    def describe(self) -> str:
        return f"the Dask cluster at {self.address}"


def connect(address: str, timeout: float = CONNECT_TIMEOUT):
    """A ``distributed.Client`` of the scheduler at ``address``, or an error naming it."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError(f"scheduler={address}: Dask's distributed is not installed; pip "
                         "install 'blockhash[distributed]'") from None
    try:
        return Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise InputError(f"the Dask scheduler at {address} did not answer within {timeout:g} s "
                         f"({exc}); check the address, or {HOW_TO_START}") from None


class _DaskSession(Session):
    def __init__(self, renderer, address: str):
        super().__init__()
        from blockhash.passes import worker

        self.client = connect(address)
        try:
            self.workers = check_workers(self.client, renderer.settings.backend)
            self.slots = 2 * self.workers  # each worker's next pass queued
            self.digest, self.data = worker.pack(renderer.spec)
            self.emitted, self.scatters = {}, 0
            self._scatter()
        except BaseException:
            self.client.close()
            raise

    def _scatter(self) -> None:
        """The render's spec on every worker (again, once a worker that held the only copy
        died: the passes that needed it are cancelled by the scheduler)."""
        [self.spec] = self.client.scatter([self.data], broadcast=True, hash=False)
        self.scatters += 1

    def submit(self, p: int, emitted) -> None:
        from blockhash.passes import worker

        self.emitted[p] = emitted
        self.flight[p] = self.client.submit(worker.run_spec, self.digest, self.spec, p, emitted,
                                            pure=False, retries=0, key=f"blockhash-pass-{p}-"
                                            f"{self.digest}-{id(self)}-{self.scatters}")

    def results(self):
        from distributed import wait

        with self.client.as_current():
            try:
                done, _ = wait(list(self.flight.values()), return_when="FIRST_COMPLETED")
            except Exception:  # noqa: BLE001 - passes cancelled with a lost spec run again
                lost = [p for p, future in self.flight.items() if future.cancelled()]
                if not lost:
                    raise
                self._scatter()
                for p in lost:
                    self.submit(p, self.emitted[p])
                return
        for p, future in sorted(self.flight.items()):
            if future not in done:
                continue
            try:
                contribution = future.result()
            except Exception as exc:  # noqa: BLE001 - any error of a pass ends the render
                raise PassFailed(p, f"on the Dask cluster at {self.client.scheduler.address}",
                                 exc) from exc
            del self.flight[p], self.emitted[p]
            yield p, contribution

    def close(self) -> None:
        for future in self.flight.values():
            future.cancel()
        super().close()
        self.client.close()


def check_workers(client, backend=None) -> int:
    """The count of the cluster's workers, once each has answered with this process's
    blockhash version and source digest and a GL context; else an error naming the worker."""
    import blockhash
    from blockhash.code_version import source_digest
    from blockhash.passes import worker

    names = list(client.scheduler_info(n_workers=-1)["workers"])
    if not names:
        raise InputError(f"the Dask cluster at {client.scheduler.address} has no workers; start "
                         f"some with `dask worker {client.scheduler.address} --nthreads 1`")
    def on_each(fn, args):
        return {name: client.submit(fn, *args(name), workers=[name], allow_other_workers=False,
                                    pure=False) for name in names}
    hosts = {name: f.result() for name, f in on_each(worker.host, lambda _: ()).items()}
    sharing = {}
    for h in hosts.values():
        sharing[h["host"]] = sharing.get(h["host"], 0) + 1
    futures = on_each(worker.identity, lambda name: (
        backend, max(1, hosts[name]["cores"] // sharing[hosts[name]["host"]])))
    ours = (blockhash.__version__, source_digest())
    for name, future in futures.items():
        who = future.result()
        theirs = (who["version"], who["digest"])
        if theirs != ours:
            raise InputError(
                f"Dask worker {name} runs blockhash {theirs[0]} (source {theirs[1]}), this "
                f"process {ours[0]} (source {ours[1]}); install the same blockhash on every "
                "worker (pip install the same wheel or checkout) and restart them")
        if who["gl"] is None:
            raise InputError(f"Dask worker {name} has no OpenGL 4.5 context ({who['gl_error']}); "
                             "install Mesa's EGL or OSMesa there (apt-get install libegl1 "
                             "libegl-mesa0 libgl1-mesa-dri libosmesa6) or an NVIDIA driver, and "
                             "restart the worker")
    return len(names)
