"""The wheel holds every module and every shader file; pyproject's package list matches the tree."""

import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest
from project_tree import skipped_dir

ROOT = Path(__file__).resolve().parents[1]


def _tree_packages() -> set[str]:
    pkgs = {".".join(p.parent.relative_to(ROOT).parts)
            for p in (ROOT / "blockhash").rglob("__init__.py") if "__pycache__" not in p.parts}
    return pkgs | {"blockhash.glsl"}


def _tree_files() -> set[str]:
    """Wheel member names that the tree says must be shipped."""
    modules = {p.relative_to(ROOT).as_posix() for p in (ROOT / "blockhash").rglob("*.py")
               if "__pycache__" not in p.parts}
    shaders = {f"blockhash/glsl/{p.name}" for p in (ROOT / "glsl").iterdir()
               if p.is_file() and p.suffix != ".pyc"}
    return modules | shaders


def test_pyproject_lists_every_package_in_the_tree():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert set(config["packages"]) == _tree_packages()
    assert config["package-dir"]["blockhash.glsl"] == "glsl"
    assert config["package-data"]["blockhash.glsl"] == ["*"]


def _build_wheel(out: Path) -> Path:
    """Build from a copy of the tree: setuptools reuses a checkout's stale build/ folder. The
    copy leaves out what is no part of the project (a virtual environment, caches, builds)."""
    src = out / "src"
    shutil.copytree(ROOT, src, ignore=lambda d, names: [
        n for n in names if (Path(d) / n).is_dir() and skipped_dir(Path(d) / n)])
    base = [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(out), str(src)]
    run = subprocess.run(base + ["--no-build-isolation"], capture_output=True, text=True)
    if run.returncode != 0:  # setuptools or wheel missing here: let pip fetch them
        run = subprocess.run(base, capture_output=True, text=True)
    if run.returncode != 0:
        pytest.fail(f"building the wheel failed:\n{run.stderr[-3000:]}")
    (wheel,) = out.glob("blockhash-*.whl")
    return wheel


@pytest.fixture(scope="module")
def wheel_path(tmp_path_factory) -> Path:
    return _build_wheel(tmp_path_factory.mktemp("wheel"))


@pytest.fixture(scope="module")
def wheel_names(wheel_path) -> set[str]:
    return set(zipfile.ZipFile(wheel_path).namelist())


@pytest.mark.slow
def test_wheel_holds_every_module_and_shader_file(wheel_names):
    missing = sorted(_tree_files() - wheel_names)
    assert not missing, f"the wheel lacks {missing}; fix pyproject.toml's packages or package-data"


@pytest.mark.slow
def test_wheel_holds_the_shaders_each_program_needs(wheel_names):
    for name in ("bh_query.frag", "caustic_pass.frag", "kd_query.frag", "bh_lookup.glsl"):
        assert f"blockhash/glsl/{name}" in wheel_names


def test_wheel_declares_the_command_line(wheel_path):
    archive = zipfile.ZipFile(wheel_path)
    (entry,) = [n for n in archive.namelist() if n.endswith(".dist-info/entry_points.txt")]
    assert "blockhash = blockhash.cli:main" in archive.read(entry).decode()


def test_tree_file_check_sees_a_missing_shader(wheel_names):
    """The comparison itself can fail: a shader removed from the wheel's names is reported."""
    assert "blockhash/glsl/caustic_pass.frag" in _tree_files() - (wheel_names - {"blockhash/glsl/caustic_pass.frag"})
