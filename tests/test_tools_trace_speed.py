"""tools/trace_speed.py on a tiny input: the host tracer, the Dr.Jit kernels and Mitsuba's
particle tracer on one scene (skipped without Mitsuba's LLVM variant)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import mitsuba_or_skip

TOOL = Path(__file__).resolve().parents[1] / "tools" / "trace_speed.py"


def test_trace_speed_writes_the_three_rates_and_matching_stored_fractions(tmp_path):
    mitsuba_or_skip()  # pytest.skip when mitsuba does not import (fails under CI's flag)
    from blockhash.device.choice import resolve
    from blockhash.errors import InputError

    try:
        resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")
    out = tmp_path / "speed.json"
    run = subprocess.run([sys.executable, str(TOOL), "--scenes", "ring", "--photons", "20000",
                          "--repeat", "1", "--size", "64", "--spp", "4", "--json", str(out)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    [row] = json.loads(out.read_text())["rows"]
    host, kern, peer = row["host"], row["kernels"], row["ptracer"]
    assert (host["device"], kern["device"]) == ("host", "cpu")
    assert host["stored"] == kern["stored"] == 20000
    assert host["stored_per_s"] > 0 and kern["stored_per_s"] > 0 and peer["paths_per_s"] > 0
    # the same emitter tables aim both tracers' photons: the same share of them is stored
    assert abs(kern["stored_per_emitted"] / host["stored_per_emitted"] - 1) < 0.05
    assert "| ring |" in run.stdout
