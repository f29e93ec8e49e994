"""README's quick start runs: each command line of its first block, on a small input."""

import re
import shlex
import subprocess
import sys
import tomllib

from project_tree import ROOT

README = (ROOT / "README.md").read_text()


def quick_start() -> list[str]:
    """The lines of README's first ```bash block (the quick start)."""
    block = re.search(r"```bash\n(.*?)```", README, flags=re.S)
    assert block, "README has no ```bash block"
    return [line for line in block.group(1).splitlines() if line.strip()]


def commands(line: str) -> list[list[str]]:
    return [shlex.split(part) for part in line.split("&&")]


def test_the_quick_start_is_an_install_then_a_render_and_an_install_then_the_tests():
    lines = quick_start()
    assert len(lines) == 2, lines
    (install, render), (install_test, run_tests) = commands(lines[0]), commands(lines[1])
    assert install == ["python", "-m", "pip", "install", "."]
    assert render[:2] == ["blockhash", "render"]
    assert install_test[:5] == ["python", "-m", "pip", "install", "-e"]
    extras = re.fullmatch(r"\.\[([\w,-]+)\]", install_test[5]).group(1).split(",")
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert set(extras) <= set(declared), f"README installs extras {extras}; pyproject has {sorted(declared)}"
    assert run_tests == ["python", "-m", "pytest"]


def test_the_quick_start_render_writes_the_exr_and_the_png(tmp_path):
    """The first line's render, from a folder outside the checkout, smaller (the install is
    the environment this runs in)."""
    render = commands(quick_start()[0])[1]
    args = [str(ROOT / a) if (ROOT / a).is_file() else a for a in render[1:]]
    run = subprocess.run([sys.executable, "-m", "blockhash", *args, "--size", "64x64",
                          "--photons", "20000"], cwd=tmp_path, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    stem = next(a for a in render if a.endswith(".toml")).rsplit("/", 1)[-1][:-len(".toml")]
    for out in (f"{stem}.exr", f"{stem}.png"):
        assert (tmp_path / out).stat().st_size > 0, f"{out} was not written"
