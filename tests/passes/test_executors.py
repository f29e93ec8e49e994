"""Passes as tasks on every executor: the image of passes 0..N-1 is the same in this process,
in local worker processes and on a Dask cluster, whatever order they end in, after a worker
dies mid-render; errors name the pass, the worker, the address or the flag."""

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.errors import InputError
from blockhash.passes import worker
from blockhash.passes.executors import (
    MAX_START_FAILURES,
    MAX_WORKER_DEATHS,
    InProcess,
    LocalWorkers,
    PassFailed,
    WorkersFailed,
    worker_count,
)
from blockhash.passes.plan import RenderPlan
from blockhash.passes.renderer import Renderer
from blockhash.passes.run import run_passes
from blockhash.passes.task import PassSettings, RenderSetup, run_pass

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

RING = Path(__file__).resolve().parents[2] / "scenes" / "ring.toml"
PHOTONS = 4000
PASSES = 5


@pytest.fixture(scope="module")
def scene():
    return blockhash.load_scene(RING).with_size(32, 32)


@pytest.fixture(scope="module")
def one_process(scene):
    """The in-process render of passes 0..PASSES-1: the image every executor must give."""
    r = Renderer(scene, photons=PHOTONS)
    run_passes(r, RenderPlan(passes=PASSES))
    return r


def _render(scene, executor, passes=PASSES, on_pass=None):
    r = Renderer(scene, photons=PHOTONS)
    why = run_passes(r, RenderPlan(passes=passes, executor=executor), on_pass=on_pass)
    return r, why


def assert_same_image(r, ref):
    assert r.passes == ref.passes
    assert r.emitted == ref.emitted and r.stored == ref.stored
    image, want = r.image, ref.image
    for name in ("direct", "caustic"):
        np.testing.assert_array_equal(getattr(image, name), getattr(want, name), err_msg=name)
    np.testing.assert_array_equal(r.film.caustic_variance, ref.film.caustic_variance)


def test_a_pass_is_a_function_of_setup_and_pass_number(scene):
    """The same (seed, p) gives the same contribution, whichever setup runs it and in which
    order: pass 3 before pass 1 in a fresh setup equals pass 3 after passes 0..2."""
    settings = PassSettings.of(scene, photons=PHOTONS)
    a, b = RenderSetup(scene, settings), RenderSetup(scene, settings)
    first = run_pass(a, 0)
    in_order = [run_pass(a, p, first.emitted) for p in (1, 2, 3)]
    late = run_pass(b, 3, first.emitted)
    np.testing.assert_array_equal(late.caustic, in_order[2].caustic)
    np.testing.assert_array_equal(late.direct, in_order[2].direct)
    assert late.emitted == first.emitted and late.stored == in_order[2].stored


def test_passes_merge_in_pass_order_whatever_order_they_end(scene, one_process):
    settings = PassSettings.of(scene, photons=PHOTONS)
    setup = RenderSetup(scene, settings)
    first = run_pass(setup, 0)
    rest = [run_pass(setup, p, first.emitted).portable() for p in range(1, PASSES)]
    r = Renderer(scene, photons=PHOTONS)
    assert [s.index for s in r.merge(first)] == [0]
    assert r.merge(rest[3]) == [] and r.merge(rest[1]) == [] and r.passes == 1
    assert [s.index for s in r.merge(rest[0])] == [1, 2]
    assert [s.index for s in r.merge(rest[2])] == [3, 4]
    assert_same_image(r, one_process)
    with pytest.raises(ValueError, match="pass 2 is already in the film"):
        r.merge(rest[1])


def test_local_workers_give_the_one_process_image(scene, one_process):
    r, why = _render(scene, LocalWorkers(2))
    assert why == f"{PASSES} passes" and r.info["workers"] == 2
    assert_same_image(r, one_process)


def test_a_local_worker_killed_mid_render_costs_time_not_the_image(scene, one_process):
    killed = []

    def kill_one(renderer, stats, elapsed, session):
        if stats.index == 1 and not killed:
            pid = next(iter(session.pool._processes))  # one of the pool's worker processes
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
    r, _ = _render(scene, LocalWorkers(2), on_pass=kill_one)
    assert killed
    assert_same_image(r, one_process)


# Stand-ins for worker.start and worker.run, run in the pool's spawned processes (pickled by
# reference to this module): after pass 1, a file named by $BLOCKHASH_TEST_BROKEN marks the
# workers broken; a marked worker dies in any later pass, and at start-up.

def _marked():
    return Path(os.environ["BLOCKHASH_TEST_BROKEN"]).exists()


def _start_unless_marked(*args):
    if _marked():
        os.kill(os.getpid(), signal.SIGKILL)
    worker.start(*args)


def _run_then_mark(p, emitted):
    if p >= 2 and _marked():
        os.kill(os.getpid(), signal.SIGKILL)
    contribution = worker.run(p, emitted)
    if p == 1:
        Path(os.environ["BLOCKHASH_TEST_BROKEN"]).touch()
    return contribution


@pytest.fixture
def broken_after_pass_1(monkeypatch, tmp_path):
    monkeypatch.setenv("BLOCKHASH_TEST_BROKEN", str(tmp_path / "broken"))
    monkeypatch.setattr(worker, "run", _run_then_mark)
    return monkeypatch


def test_a_pass_whose_worker_keeps_dying_ends_the_render_keeping_the_passes_before(
        scene, one_process, broken_after_pass_1):
    with pytest.raises(PassFailed, match=rf"pass \d failed in a local worker process: .*died "
                       rf"{MAX_WORKER_DEATHS} times \(.*killed by SIGKILL") as caught:
        blockhash.render(scene, photons=PHOTONS, plan=RenderPlan(passes=PASSES, executor=LocalWorkers(2)))
    image = caught.value.image
    assert 2 <= image.passes < PASSES and image.passes == caught.value.pass_index
    want = Renderer(scene, photons=PHOTONS)
    run_passes(want, RenderPlan(passes=image.passes))
    np.testing.assert_array_equal(image.caustic, want.image.caustic)  # the passes merged before


def test_workers_that_die_at_start_up_on_every_replacement_end_the_render(
        scene, broken_after_pass_1):
    broken_after_pass_1.setattr(worker, "start", _start_unless_marked)
    t0 = time.perf_counter()
    with pytest.raises(WorkersFailed, match=rf"died before they started, {MAX_START_FAILURES} "
                       r"pools in a row \(killed by SIGKILL\)") as caught:
        blockhash.render(scene, photons=PHOTONS, plan=RenderPlan(passes=PASSES, executor=LocalWorkers(2)))
    assert time.perf_counter() - t0 < 120  # not a pool replaced without end
    assert caught.value.image.passes >= 2  # passes 0 and 1 ran before the workers broke


def test_workers_whose_start_raises_end_the_render_naming_the_exception(scene, monkeypatch, tmp_path):
    gone = tmp_path / "no-such-spec.pickle"  # the workers' start cannot read the render's spec
    monkeypatch.setattr(worker, "spec_file", lambda packed: (packed[0], str(gone)))
    with pytest.raises(WorkersFailed, match=rf"died before they started, {MAX_START_FAILURES} pools "
                                            r"in a row \(exit code \d+: FileNotFoundError: .*no-such-spec"
                       ) as caught:
        blockhash.render(scene, photons=PHOTONS, plan=RenderPlan(passes=2, executor=LocalWorkers(1)))
    assert caught.value.image is None  # no pass had merged


def test_exit_codes_are_named():
    from blockhash.passes.executors import exit_reason

    assert exit_reason(-9) == "killed by SIGKILL" and exit_reason(3) == "exit code 3"


def test_worker_counts_are_checked():
    assert worker_count("auto") >= 1 and worker_count("3") == 3
    for bad in (0, -1, "0", "two", 1.5, True):
        with pytest.raises(InputError, match="workers=.*count >= 1 or 'auto'"):
            LocalWorkers(bad)
    with pytest.raises(InputError, match=r"workers=-2: local worker processes") as caught:
        worker_count("-2")
    assert caught.value.spelled({"workers": "--workers "}).startswith("--workers -2: local")
    with pytest.raises(InputError, match="executor="):
        RenderPlan(executor="dask")


@pytest.mark.parametrize("argv, match", [
    (["--workers", "0"], r"--workers 0: local worker processes are a count >= 1"),
    (["--workers", "-3"], r"--workers -3: local worker processes are a count >= 1"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], r"--workers 2 and --scheduler"),
])
def test_the_render_command_refuses_bad_executor_flags(tmp_path, capsys, argv, match):
    from blockhash.cli import main

    out = tmp_path / "ring.exr"
    assert main(["render", str(RING), "--size", "16x16", "--photons", "1000", "-o", str(out),
                 *argv]) == 2
    assert pytest.importorskip("re").search(match, capsys.readouterr().err)
    assert not out.exists()


def test_the_render_command_with_workers_writes_the_one_process_image(tmp_path, capsys):
    from blockhash.cli import main
    from blockhash.evaluate.images import read_attribute, read_layers

    images = {}
    for name, extra in (("one", []), ("two", ["--workers", "2"])):
        out = tmp_path / f"{name}.exr"
        assert main(["render", str(RING), "--size", "24x24", "--photons", "3000", "--passes", "4",
                     "-o", str(out), *extra]) == 0
        images[name] = read_layers(out)
        assert read_attribute(out, "blockhash:passes") == 4
    assert "2 local worker processes" in capsys.readouterr().out
    for layer in images["one"]:
        np.testing.assert_array_equal(images["one"][layer], images["two"][layer])


# --- Dask ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as c:
        yield c


@pytest.fixture
def threads_cluster():
    """A cluster of worker threads in this process: what a test patches reaches its tasks."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as c:
        yield c


def test_a_dask_cluster_gives_the_one_process_image(scene, one_process, cluster):
    from blockhash.passes.dask_cluster import DaskCluster

    r, why = _render(scene, DaskCluster(cluster.scheduler_address))
    assert why == f"{PASSES} passes" and r.info["workers"] == 2
    assert_same_image(r, one_process)


def test_a_dask_worker_killed_mid_render_costs_time_not_the_image(scene, one_process, cluster):
    from distributed import Client

    from blockhash.passes.dask_cluster import DaskCluster

    with Client(cluster.scheduler_address, set_as_default=False) as client:
        pids = list(client.run(os.getpid).values())
    killed = []

    def kill_one(renderer, stats, elapsed, session):
        if stats.index == 1 and not killed:
            os.kill(pids[0], signal.SIGKILL)  # a worker process; its nanny starts another
            killed.append(pids[0])
    r, _ = _render(scene, DaskCluster(cluster.scheduler_address), passes=PASSES + 3,
                   on_pass=kill_one)
    assert killed
    ref = Renderer(scene, photons=PHOTONS)
    run_passes(ref, RenderPlan(passes=PASSES + 3))
    assert_same_image(r, ref)


def test_the_only_worker_killed_mid_render_loses_the_spec_and_the_render_scatters_it_again(
        scene, one_process):
    """One worker: killing it loses the only copy of the scattered spec, which cancels the
    passes in flight; the render scatters the spec to the restarted worker and runs them."""
    distributed = pytest.importorskip("distributed")
    from blockhash.passes.dask_cluster import DaskCluster

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as single:
        with distributed.Client(single.scheduler_address, set_as_default=False) as client:
            [pid] = client.run(os.getpid).values()
        killed = []

        def kill(renderer, stats, elapsed, session):
            if stats.index == 1 and not killed:
                os.kill(pid, signal.SIGKILL)  # its nanny starts another, without the spec
                killed.append(session)
        r, _ = _render(scene, DaskCluster(single.scheduler_address), passes=PASSES,
                       on_pass=kill)
    assert killed and killed[0].scatters >= 2  # scattered again
    assert_same_image(r, one_process)


def test_a_pass_that_raises_on_a_worker_stops_the_render_with_its_number(scene, threads_cluster,
                                                                          monkeypatch):
    from blockhash.passes import task
    from blockhash.passes.dask_cluster import DaskCluster

    real = task.run_pass

    def failing(setup, p, emitted=None):
        if p == 2:
            raise RuntimeError("the GPU fell off the bus")
        return real(setup, p, emitted)
    monkeypatch.setattr(task, "run_pass", failing)
    worker._SETUPS.clear()
    r = Renderer(scene, photons=PHOTONS)
    with pytest.raises(PassFailed, match=r"pass 2 failed on the Dask cluster at .*GPU fell off"):
        run_passes(r, RenderPlan(passes=PASSES, executor=DaskCluster(threads_cluster.scheduler_address)))
    assert r.passes == 2  # the image of the passes done: 0 and 1


@pytest.mark.parametrize("field, value, match", [
    ("version", "0.0.1", r"runs blockhash 0\.0\.1 .* install the same blockhash on every worker"),
    ("gl", None, r"has no OpenGL 4\.5 context \(no EGL here\); install Mesa"),
])
def test_a_dask_worker_of_another_version_or_without_gl_is_refused(scene, threads_cluster,
                                                                   monkeypatch, field, value, match):
    from blockhash.passes.dask_cluster import DaskCluster

    real = worker._identity

    def other(backend):
        return {**real(backend), field: value, "gl_error": "no EGL here"}
    monkeypatch.setattr(worker, "_identity", other)
    with pytest.raises(InputError, match=r"Dask worker (tcp|inproc)://\S+ " + match):
        blockhash.render(scene, photons=PHOTONS, plan=RenderPlan(
            passes=2, executor=DaskCluster(threads_cluster.scheduler_address)))


def test_a_scheduler_that_does_not_answer_is_named_within_30_s(tmp_path, capsys):
    pytest.importorskip("distributed")
    from blockhash.cli import main

    out = tmp_path / "ring.exr"
    t0 = time.perf_counter()
    code = main(["render", str(RING), "--size", "16x16", "--photons", "1000", "-o", str(out),
                 "--scheduler", "tcp://127.0.0.1:9"])
    assert code == 2 and time.perf_counter() - t0 < 30
    err = capsys.readouterr().err
    assert "the Dask scheduler at tcp://127.0.0.1:9 did not answer" in err
    assert "dask scheduler" in err and "dask worker" in err
    assert not out.exists()


def test_in_process_is_the_default(scene, one_process):
    assert isinstance(RenderPlan().executor, InProcess)
    r, _ = _render(scene, InProcess())
    assert r.info["workers"] == 1 and r.info["executor"] == "in this process"
    assert_same_image(r, one_process)


def test_ctrl_c_with_local_workers_writes_the_passes_so_far_and_stops_them(tmp_path):
    """SIGINT to the whole process group, as a terminal sends it: the driver writes the image of
    the passes merged and exits 130 at once; the workers ignore it and are stopped."""
    import signal
    import subprocess
    import sys

    from blockhash.evaluate.images import read_attribute

    out = tmp_path / "ring.exr"
    proc = subprocess.Popen(
        [sys.executable, "-m", "blockhash", "render", str(RING), "--size", "24x24", "--photons",
         "3000", "--passes", "100000", "--workers", "2", "-o", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.time() + 120
    while time.time() < deadline and not out.with_suffix(".png").exists():
        time.sleep(0.2)  # (the PNG is written only at the end: wait for some passes instead)
        if proc.poll() is not None:
            break
        if time.time() > deadline - 110:
            break
    time.sleep(4)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    passes = read_attribute(out, "blockhash:passes")
    assert passes >= 1 and f"wrote the image of {passes} pass" in err
    assert read_attribute(out, "blockhash:stopped") == "interrupted (Ctrl-C)"


def test_area_and_directional_lights_give_the_one_process_image_on_workers():
    """A scene with an area light and one with sunlight: pass 3 alone equals pass 3 after
    0..2 (the light samples follow the pass number), and local workers give the in-process
    image bit for bit."""
    for name in ("cbox", "sun"):
        scene = blockhash.load_scene(RING.parent / f"{name}.toml").with_size(24, 24)
        settings = PassSettings.of(scene, photons=2000)
        a, b = RenderSetup(scene, settings), RenderSetup(scene, settings)
        first = run_pass(a, 0)
        in_order = [run_pass(a, p, first.emitted) for p in (1, 2, 3)]
        late = run_pass(b, 3, first.emitted)
        np.testing.assert_array_equal(late.direct, in_order[2].direct)
        np.testing.assert_array_equal(late.caustic, in_order[2].caustic)
        assert not np.array_equal(in_order[0].direct, in_order[1].direct) or name == "sun"
        here = Renderer(scene, photons=2000)
        run_passes(here, RenderPlan(passes=3))
        there = Renderer(scene, photons=2000)
        run_passes(there, RenderPlan(passes=3, executor=LocalWorkers(2)))
        assert_same_image(there, here)


# A pass whose caustic holds one NaN pixel (x=3, y=2) in pass 1: stand-ins for the pass on
# each executor (in this process, in a spawned local worker, on a Dask worker thread).

def _nan_in_pass_1(contribution):
    if contribution.index == 1:
        contribution.caustic[2, 3, 1] = np.nan
    return contribution


def _run_pass_with_nan(*args, **kw):
    return _nan_in_pass_1(run_pass(*args, **kw))  # this module's name: the real run_pass


def _worker_run_with_nan(p, emitted):
    return _nan_in_pass_1(worker.run(p, emitted))


NAN_PASS = (r"pass 1 \(rendered {where}\): the caustic layer has 1 non-finite pixel \(NaN or "
            r"infinity\) of 1,024, the first at x=3, y=2; nothing was merged")


def test_a_pass_with_a_nan_pixel_ends_the_render_naming_it_in_process(scene, monkeypatch):
    from blockhash.errors import NonFiniteError
    from blockhash.passes import executors

    monkeypatch.setattr(executors, "run_pass", _run_pass_with_nan)
    with pytest.raises(NonFiniteError, match=NAN_PASS.format(where="in this process")) as caught:
        blockhash.render(scene, photons=PHOTONS, plan=RenderPlan(passes=3))
    assert caught.value.image.passes == 1 and np.isfinite(caught.value.image.caustic).all()


def test_a_pass_with_a_nan_pixel_ends_the_render_naming_its_local_worker(scene, monkeypatch):
    from blockhash.errors import NonFiniteError

    monkeypatch.setattr(worker, "run", _worker_run_with_nan)
    with pytest.raises(NonFiniteError, match=NAN_PASS.format(where=r"by worker process \d+ on \S+")):
        blockhash.render(scene, photons=PHOTONS, plan=RenderPlan(passes=3, executor=LocalWorkers(2)))


def test_a_pass_with_a_nan_pixel_ends_the_render_naming_its_dask_worker(scene, monkeypatch,
                                                                       threads_cluster):
    from blockhash.errors import NonFiniteError
    from blockhash.passes import task
    from blockhash.passes.dask_cluster import DaskCluster

    monkeypatch.setattr(task, "run_pass", _run_pass_with_nan)
    worker._SETUPS.clear()
    with pytest.raises(NonFiniteError, match=NAN_PASS.format(where=r"by worker process \d+ on \S+")):
        blockhash.render(scene, photons=PHOTONS, plan=RenderPlan(
            passes=3, executor=DaskCluster(threads_cluster.scheduler_address)))
