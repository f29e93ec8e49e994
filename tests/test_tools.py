"""Every command in tools/ that the docs quote starts: its imports resolve against the
package as it is laid out now, and ``--help`` prints its usage without running it."""

import subprocess
import sys
from pathlib import Path

import pytest
from conftest import run_tool

ROOT = Path(__file__).resolve().parents[1]
TOOLS = sorted((ROOT / "tools").glob("*.py"))


@pytest.mark.slow
@pytest.mark.parametrize("tool", TOOLS, ids=lambda p: p.name)
def test_each_tool_imports_and_prints_its_usage(tool):
    run = subprocess.run([sys.executable, str(tool), "--help"], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "usage:" in run.stdout, run.stdout[-500:]


@pytest.mark.gl
def test_pass_scaling_writes_the_executors_rows_and_their_images_agree(tmp_path):
    out = tmp_path / "scaling.json"
    text = run_tool("pass_scaling.py", ["--scenes", "ring", "--sizes", "24",
                 "--photons", "2000", "--passes", "3", "--warm", "1", "--workers", "1",
                 "--dask", "", "--json", out], tmp_path)
    rows = __import__("json").loads(out.read_text())["rows"]
    assert [r["executor"] for r in rows] == ["in process", "1 local worker"]
    assert all(r["warm_photons_per_s"] > 0 and len(r["ends"]) == 3 for r in rows)
    assert rows[1]["max_diff"] == 0.0  # the worker's image is the in-process one
    assert "| ring | 24 | 1 local worker |" in text


@pytest.mark.gl
def test_pass_stages_writes_each_stage_beside_a_baseline(tmp_path):
    out = tmp_path / "stages.json"
    text = run_tool("pass_stages.py", ["--baseline", ROOT, "--scenes", "ring",
                 "--sizes", "24", "--photons", "2000", "--passes", "1", "--json", out], tmp_path)
    [row] = __import__("json").loads(out.read_text())["rows"]
    for side in ("baseline", "this"):
        assert row[side]["stored"] > 1000 and row[side]["seconds"]["trace"] > 0
        assert row[side]["stored_per_s"] > 0
    # the same checkout on both sides: the same photons, whatever the seconds
    assert row["baseline"]["stored"] == row["this"]["stored"]
    assert "| ring | 24 | 2,000 | speed-up |" in text


@pytest.mark.gl
def test_pass_memory_writes_the_peaks_of_each_pass_count(tmp_path):
    text = run_tool("pass_memory.py", ["--photons", "2000", "--passes", "1,3",
                 "--size", "24", "--marks", "1,3"], tmp_path)
    rows = [line for line in text.splitlines() if line.startswith("| default |")]
    assert [line.split("|")[2].strip() for line in rows] == ["1", "3"]
    peak = float(rows[-1].split("|")[4])
    assert 50 < peak < 5000  # MiB: a real process's resident set
