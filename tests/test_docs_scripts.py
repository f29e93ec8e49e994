"""Every page's Python examples run as the script a user pastes them into: each page's blocks
(those Sybil runs, in page order) saved as one file and run with ``python FILE`` from the
repository's root in a fresh interpreter, within a time limit.  Sybil runs the same blocks in
pytest's process, whose main module is pytest's own; only a script shows what a spawned
worker process does with the user's main module (docs/workers.md, "Local workers from a
script")."""

import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import context_or_skip

ROOT = Path(__file__).resolve().parents[1]
PAGES = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md"))]
#: Seconds a page's examples may take as one script (each runs in a second or two in pytest).
LIMIT = 240

BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def page_script(page: str) -> str:
    """The page's Python blocks in order, less a block after ``<!-- skip: next -->``."""
    text = (ROOT / page).read_text()
    blocks, last = [], 0
    for m in BLOCK.finditer(text):
        if "<!-- skip: next -->" not in text[last:m.start()]:
            blocks.append(m.group(1))
        last = m.end()
    return "\n".join(blocks)


def test_the_script_of_a_page_is_its_blocks_less_the_skipped():
    script = page_script("docs/workers.md")
    assert "LocalWorkers(2)" in script and "DaskCluster(" not in script


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if BLOCK.search((ROOT / p).read_text())])
def test_a_pages_examples_run_as_a_script(page, tmp_path):
    context_or_skip("egl")
    script = tmp_path / (Path(page).stem + "_example.py")
    script.write_text(page_script(page))
    try:
        run = subprocess.run([sys.executable, str(script)], cwd=ROOT, capture_output=True,
                             text=True, timeout=LIMIT)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"{page}'s examples as a script ran past {LIMIT} s (a hang?):\n"
                    f"{(exc.stderr or b'')[-3000:]}")
    assert run.returncode == 0, f"{page}'s examples as a script failed:\n{run.stderr[-3000:]}"


UNGUARDED = """
import blockhash
from blockhash import LocalWorkers, RenderPlan

scene = blockhash.load_scene("scenes/ring.toml").with_size(16, 16)
blockhash.render(scene, photons=2_000, plan=RenderPlan(passes=2, executor=LocalWorkers(2)))
"""


@pytest.mark.gl
def test_an_unguarded_script_with_local_workers_ends_within_seconds_naming_the_guard(tmp_path):
    context_or_skip("egl")
    script = tmp_path / "unguarded.py"
    script.write_text(UNGUARDED)
    run = subprocess.run([sys.executable, str(script)], cwd=ROOT, capture_output=True, text=True,
                         timeout=120)  # it hung without end before the executors gave up
    assert run.returncode == 1
    assert "WorkersFailed" in run.stderr and 'if __name__ == "__main__":' in run.stderr
    assert str(script) in run.stderr  # names the script
    assert "bootstrapping phase" not in run.stderr  # each worker stops before multiprocessing's error
