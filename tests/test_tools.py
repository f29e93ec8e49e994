"""Every command in tools/ that the docs quote starts: its imports resolve against the
package as it is laid out now, and ``--help`` prints its usage without running it."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TOOLS = sorted((ROOT / "tools").glob("*.py"))


@pytest.mark.slow
@pytest.mark.parametrize("tool", TOOLS, ids=lambda p: p.name)
def test_each_tool_imports_and_prints_its_usage(tool):
    run = subprocess.run([sys.executable, str(tool), "--help"], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "usage:" in run.stdout, run.stdout[-500:]
