"""The tests that read the tree read only the project's files: a virtual environment, a
scratch folder or a build output inside the checkout changes nothing they find."""

import re
import shutil
import subprocess
import sys

import pytest
from project_tree import ROOT, _walked, project_files
from test_docs import OUTSIDE, outside_hits

# One line for each pattern test_docs forbids, built from pieces so this file holds none.
DECOY = "\n".join(["see " + ".." + "/shared/notes", "DESIGN" + ".md says so", "/wo" + "rk/main",
                   "done in this " + "session", "fixed (is" + "sue 12)"]) + "\n"


@pytest.fixture
def decoys():
    """Untracked folders a user keeps in the checkout, each holding every forbidden phrase:
    a scratch folder git does not ignore, a virtual environment and a build output."""
    made = [ROOT / "decoy-scratch", ROOT / ".venv-decoy", ROOT / "venv-decoy"]
    for top in made:
        assert not top.exists(), f"{top} is in the way of the decoy test"
    (ROOT / "venv-decoy").mkdir()
    (ROOT / "venv-decoy" / "pyvenv.cfg").write_text("home = /usr/bin\n")
    files = []
    for top in made + [ROOT / "decoy-scratch" / "build", ROOT / "decoy-scratch" / "dist"]:
        for rel in ("notes.md", "lib/python3.11/site-packages/pkg/mod.py", "scene.toml"):
            f = top / rel
            f.parent.mkdir(parents=True, exist_ok=True)
            f.write_text(DECOY)
            files.append(f)
    try:
        yield files
    finally:
        for top in made:
            shutil.rmtree(top, ignore_errors=True)


def test_the_decoys_hold_every_forbidden_phrase(decoys):
    """The check would fail on them if it read them: each pattern finds each decoy."""
    for pattern in OUTSIDE:
        assert len(outside_hits(pattern, decoys)) == len(decoys), pattern


def test_project_files_leave_out_what_the_user_put_in_the_checkout(decoys):
    tracked = set(project_files())
    assert ROOT / "README.md" in tracked and ROOT / "tests" / "project_tree.py" in tracked
    assert not tracked & set(decoys)
    # Without git (an unpacked sdist) the walk leaves out the environments and build outputs;
    # a plain folder it cannot tell from the project's own.
    walked = set(_walked(ROOT))
    assert ROOT / "README.md" in walked
    plain = {f for f in decoys if f.is_relative_to(ROOT / "decoy-scratch")
             and not {"site-packages", "build", "dist"} & set(f.parts)}
    assert plain and plain <= walked
    assert not (set(decoys) - plain) & walked


@pytest.mark.slow
def test_the_tree_scanning_tests_pass_with_decoys_in_the_checkout(decoys):
    """The docs' phrase check and the layout checks (ruff included) pass with the decoys
    there, as they do on a clone with ``.venv`` inside it."""
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          "tests/test_docs.py", "tests/test_layout.py"],
                         cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-2000:]
    assert re.search(r"\d+ passed", run.stdout), run.stdout[-500:]


def test_ci_runs_readmes_test_command_from_a_venv_inside_the_clone():
    readme = (ROOT / "README.md").read_text()
    command = re.search(r"```bash\n[^\n]*\n([^\n]*pytest[^\n]*)\n```", readme).group(1)
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert command in ci, f".ci/run no longer runs README's test command {command!r}"
    before = ci[:ci.index(command)]
    assert "python -m venv .venv || { echo \"python -m venv .venv failed\" >&2; exit 1; }" in before
    assert ". .venv/bin/activate" in before
    assert ".venv/" in (ROOT / ".gitignore").read_text().splitlines()
