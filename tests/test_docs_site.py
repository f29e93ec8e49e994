"""The documentation site builds with warnings as errors (as CI builds it), and its API
reference documents every public name."""

import subprocess
import sys

import pytest
from project_tree import ROOT

import blockhash


def test_the_site_builds_with_warnings_as_errors(tmp_path):
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_parser")
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                          "-d", str(tmp_path / "doctrees"), str(ROOT / "docs"), str(tmp_path / "html")],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, f"the docs site did not build:\n{run.stderr[-4000:]}"
    for page in ("index", "getting-started", "rendering", "scene-format", "mitsuba", "workers",
                 "image-tests", "benchmarks", "architecture", "api"):
        assert (tmp_path / "html" / f"{page}.html").is_file(), page


def test_the_api_reference_documents_every_public_name():
    api = (ROOT / "docs" / "api.md").read_text()
    missing = [name for name in blockhash.__all__ if name != "__version__"
               and f":: blockhash.{name}\n" not in api]
    assert not missing, f"docs/api.md does not document {missing}"
