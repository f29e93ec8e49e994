"""Where the photons are traced is chosen in one place (blockhash.device.choice): the names a
render accepts, the environment variable beside them, the errors that name what is missing
and the way out, and ``auto``'s fallback with one line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import blockhash
from blockhash.device import choice
from blockhash.device.choice import DEVICES, ENV, device_name, resolve
from blockhash.errors import InputError

ROOT = Path(__file__).resolve().parents[2]


def test_the_names_and_the_environment_variable(monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    assert device_name() == choice.DEFAULT == "auto"
    monkeypatch.setenv(ENV, "HOST")
    assert device_name() == "host" and resolve().name == "host" and not resolve().jit
    assert device_name("cpu") == "cpu"  # a render's own device wins over the environment


@pytest.mark.parametrize("bad", ["tpu", "", 3])
def test_a_device_that_is_not_one_names_the_choices(bad):
    with pytest.raises(InputError, match=r"device is .*; expected one of auto, cpu, gpu, host"):
        device_name(bad)


def test_a_bad_environment_variable_names_itself(monkeypatch):
    monkeypatch.setenv(ENV, "quantum")
    with pytest.raises(InputError, match=r"the environment variable BLOCKHASH_DEVICE is 'quantum'"):
        device_name()


def test_a_render_plan_refuses_an_unknown_device_before_any_work():
    with pytest.raises(InputError, match="expected one of"):
        blockhash.RenderPlan(device="fpga")
    assert blockhash.RenderPlan(device="host").device == "host"
    assert set(DEVICES) == {"auto", "cpu", "gpu", "host"}


def test_a_missing_device_names_what_is_missing_and_the_way_out(monkeypatch):
    monkeypatch.setattr(choice, "_missing", lambda name: "Dr.Jit found no CUDA driver")
    choice._resolve.cache_clear()
    try:
        with pytest.raises(InputError, match=r"device 'gpu': Dr\.Jit found no CUDA driver; run on "
                                             r"a machine with an NVIDIA GPU .* or use device 'cpu'"):
            resolve("gpu")
        with pytest.raises(InputError, match=r"device 'cpu': .*pip install 'blockhash\[mitsuba\]'"):
            resolve("cpu")
    finally:
        choice._resolve.cache_clear()


def test_auto_falls_back_to_the_cpu_then_the_host_with_one_line(monkeypatch, capsys):
    missing = {"gpu": "Dr.Jit found no CUDA driver", "cpu": ""}
    monkeypatch.setattr(choice, "_missing", lambda name: missing[name])
    choice._resolve.cache_clear()
    try:
        dev = resolve("auto")
        assert (dev.name, dev.variant) == ("cpu", "llvm_ad_rgb")
        assert capsys.readouterr().err.count("\n") == 1
        resolve("auto")  # once a process
        assert capsys.readouterr().err == ""
        choice._resolve.cache_clear()
        missing["cpu"] = "the mitsuba package is not installed"
        dev = resolve("auto")
        assert dev.name == "host" and "mitsuba package is not installed" in dev.note
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "traced on the host" in err
    finally:
        choice._resolve.cache_clear()


def test_without_mitsuba_auto_traces_on_the_host(tmp_path):
    """A process where mitsuba cannot be imported (as after ``pip install .``)."""
    code = ("import sys; sys.modules['mitsuba'] = None\n"
            "from blockhash.device.choice import resolve\n"
            "d = resolve('auto'); print(d.name)\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "host"
    assert "the mitsuba package is not installed" in run.stderr


def test_the_render_says_which_device_traced_its_photons():
    scene = blockhash.load_scene(ROOT / "scenes" / "ring.toml").with_size(8, 8)
    image = blockhash.render(scene, photons=2000, plan=blockhash.RenderPlan(passes=1,
                                                                            device="host"))
    assert image.info["device"] == "host"
