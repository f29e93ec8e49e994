"""tools/drjit_trace_probe.py on a tiny input: blockhash's caustic photons against the same
photons traced in Dr.Jit over Mitsuba 3's scene (skipped without Mitsuba)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import mitsuba_or_skip

TOOL = Path(__file__).resolve().parents[1] / "tools" / "drjit_trace_probe.py"


def test_drjit_trace_probe_writes_both_rates_and_matching_stored_fractions(tmp_path):
    mitsuba_or_skip()  # pytest.skip when mitsuba does not import (fails under CI's flag)
    from blockhash.reference.mitsuba import load_mitsuba_module

    _, variant = load_mitsuba_module()
    if not variant.startswith(("llvm", "cuda")):
        pytest.skip(f"Mitsuba's {variant} is not a Dr.Jit JIT variant (no LLVM >= 16 here)")
    out = tmp_path / "probe.json"
    run = subprocess.run([sys.executable, str(TOOL), "--scenes", "ring", "--photons", "20000",
                          "--repeat", "1", "--json", str(out)], cwd=tmp_path,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    [row] = json.loads(out.read_text())["rows"]
    bh, dj = row["blockhash"], row["drjit"]
    assert row["scene"] == "ring"
    assert bh["stored_per_s"] > 0 and dj["stored_per_s"] > 0
    assert dj["stored"] > 0 and dj["cold_s"] > 0
    # the same emitter tables aim both tracers' photons: the same share of them is stored
    assert 0.5 < dj["stored_per_emitted"] / bh["stored_per_emitted"] < 2.0
    assert "| ring |" in run.stdout
