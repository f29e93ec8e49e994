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


def test_every_tool_has_a_test_that_runs_it_on_a_tiny_input():
    """Each command in tools/ is named (as "NAME.py" or "NAME.sh") by a test in
    tests/test_tools*.py that runs it and checks what it writes, beside the --help check."""
    named = "".join(p.read_text() for p in (ROOT / "tests").glob("test_tools*.py"))
    tools = sorted(p.name for p in (ROOT / "tools").iterdir() if p.suffix in (".py", ".sh"))
    untested = [t for t in tools if f'"{t}"' not in named]
    assert not untested, f"tools without a tiny-input test: {untested}"
