"""Old module names (before the data-flow layout) import the new modules for one release,
with a DeprecationWarning naming the new one (blockhash/moved.py)."""

import importlib
import sys

import pytest

from blockhash.moved import MOVED


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_name_gives_the_new_module_and_warns(old):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=f"{old} is now {MOVED[old]}"):
        module = importlib.import_module(old)
    assert module is importlib.import_module(MOVED[old])
    assert module.__name__ == MOVED[old]


def test_from_imports_of_old_names_work():
    sys.modules.pop("blockhash.render.scene_toml", None)
    with pytest.warns(DeprecationWarning):
        from blockhash.render.scene_toml import load_scene
    from blockhash.scene.loader import load_scene as new

    assert load_scene is new


def test_a_name_that_never_existed_still_fails():
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("blockhash.render.no_such_module")
