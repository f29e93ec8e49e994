"""numba's cache follows the package's version and source (blockhash/code_version.py)."""

import shutil

import numba

import blockhash
from blockhash import code_version


def test_the_cache_is_named_for_version_and_source():
    folder = code_version.cache_dir(blockhash.__version__)
    assert numba.config.CACHE_DIR == str(folder)
    digest = code_version.source_digest(parts=code_version.compiled_modules())
    assert folder.name == f"blockhash-{blockhash.__version__}-{digest}"
    assert "index/lookups/cells.py" in code_version.compiled_modules()
    from blockhash.index.lookups.cells import cell_hash
    cell_hash(1, 2, 3)
    assert cell_hash.stats.cache_path.startswith(str(folder))


def test_an_edit_to_an_inlined_helper_moves_the_cache(tmp_path):
    copy = tmp_path / "blockhash"
    shutil.copytree(code_version.PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    before = code_version.cache_dir("1.0", copy)
    assert code_version.cache_dir("1.0", copy) == before  # stable
    helper = copy / "index" / "lookups" / "cells.py"  # fmix32 is inlined into the cell query
    helper.write_text(helper.read_text().replace("0x85EBCA6B", "0x85EBCA6C"))
    assert code_version.cache_dir("1.0", copy) != before
    assert code_version.cache_dir("1.1", copy).name.startswith("blockhash-1.1-")


def test_code_version_dir_is_honoured(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert code_version.cache_dir("1.0").parent == tmp_path
