"""Old module names (before the data-flow layout) import the new modules for one release,
with a DeprecationWarning naming the new one (blockhash/moved.py)."""

import importlib
import sys

import pytest

from blockhash.moved import MOVED, OLD_FRAME


@pytest.mark.parametrize("old", sorted(m for m in MOVED if not m.startswith(OLD_FRAME + ".")))
def test_an_old_name_gives_the_new_module_and_warns(old):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=f"{old} is now {MOVED[old]}"):
        module = importlib.import_module(old)
    assert module is importlib.import_module(MOVED[old])
    assert module.__name__ == MOVED[old]


def test_from_imports_of_old_names_work():
    sys.modules.pop("blockhash.tradeoff.sweep", None)
    with pytest.warns(DeprecationWarning):
        from blockhash.tradeoff.sweep import run_sweep
    from blockhash.studies.sweep import run_sweep as new

    assert run_sweep is new


@pytest.mark.parametrize("old", ["blockhash.render.pipeline", "blockhash.render.scene_toml",
                                 "blockhash.render"])
def test_the_frames_old_package_name_fails_naming_the_new_one(old):
    """blockhash.render is the render function: its old modules cannot be imported (Python
    would bind the package over the function), and the error says where they are."""
    import blockhash

    with pytest.raises(ModuleNotFoundError, match=r"blockhash.render is the render function now.*"
                                                  r"import blockhash.frame.pipeline for "
                                                  r"blockhash.render.pipeline"):
        importlib.import_module(old)
    assert callable(blockhash.render) and blockhash.render.__module__ == "blockhash.frame.pipeline"
