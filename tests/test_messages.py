"""Library messages speak the library's terms: what blockhash raises or warns outside
``blockhash/cli/`` names Python parameters (``seeds=``, ``max_flip``), never a command-line
flag; the command line spells them as its flags in one place (``blockhash/cli/args.py``'s
``FLAGS``, through ``BlockHashError.spelled``)."""

import ast
import re

import pytest
from project_tree import ROOT, project_files

#: A command-line flag: ``--word`` not inside a longer word.
FLAG = re.compile(r"(?<![\w-])--[A-Za-z][\w-]*")
#: Another program's command quoted in a message (the Dask worker's own options).
FOREIGN_COMMAND = re.compile(r"`dask [^`]*`")


def _text(node) -> str:
    """A string constant's text, or an f-string's with ``{}`` for each value."""
    if isinstance(node, ast.JoinedStr):
        return "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in node.values)
    return node.value


def _is_message_call(node) -> bool:
    """A call that makes a message: ``warn(...)``, ``X.about(...)``, ``SomeError(...)``."""
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
    return name in ("warn", "about") or name.endswith(("Error", "Warning", "Exception"))


def message_flags(source: str) -> list[tuple[int, str]]:
    """(line, flag) of every flag in the strings of a ``raise`` or message call of ``source``."""
    hits = set()
    for node in ast.walk(ast.parse(source)):
        if not (isinstance(node, ast.Raise) or _is_message_call(node)):
            continue
        inner_fstring_parts = set()
        for sub in ast.walk(node):
            if isinstance(sub, ast.JoinedStr):
                inner_fstring_parts |= {id(v) for v in sub.values}
        for sub in ast.walk(node):
            if isinstance(sub, ast.JoinedStr) or (isinstance(sub, ast.Constant) and
                                                   isinstance(sub.value, str) and
                                                   id(sub) not in inner_fstring_parts):
                for flag in FLAG.findall(FOREIGN_COMMAND.sub("", _text(sub))):
                    hits.add((sub.lineno, flag))
    return sorted(hits)


def library_modules():
    return [p for p in project_files("*.py", under="blockhash")
            if "cli" not in p.relative_to(ROOT / "blockhash").parts]


@pytest.mark.parametrize("path", library_modules(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_library_message_names_a_flag(path):
    hits = message_flags(path.read_text())
    assert not hits, (f"{path.relative_to(ROOT)} names command-line flags in messages "
                      f"{hits}: name the parameter instead, with InputError.about('{{name}}...') "
                      "and blockhash/cli/args.py's FLAGS for the command line")


def test_the_check_finds_a_flag_in_a_raise_a_warning_and_an_fstring():
    source = '''
import warnings
def f(x):
    if x:
        raise ValueError("give --seeds 2 or more")
    warnings.warn(f"{x} is slow; use --fast", RuntimeWarning)
    raise InputError.about("{seeds}{value}: " + "see --margin", value=x)
'''
    assert [flag for _, flag in message_flags(source)] == ["--seeds", "--fast", "--margin"]


def test_the_check_passes_parameters_docstrings_and_another_programs_command():
    source = '''
def f(addr):
    """Run ``blockhash render --passes 4``."""
    parser.add_argument("--passes", help="--passes N")
    raise InputError(f"start some with `dask worker {addr} --nthreads 1`; passes=0 is refused")
'''
    assert message_flags(source) == []


def test_the_command_line_spells_the_parameters_as_its_flags(tmp_path, capsys):
    from blockhash.cli import main

    scenes = ROOT / "scenes"
    assert main(["export", str(scenes / "ring.toml"), "--to", "mitsuba", "-o", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "export with --drop-specular to write it" in err and "drop_specular" not in err
    assert main(["render", str(scenes / "ring_orbit.toml"), "--frames", "7:3"]) == 2
    err = capsys.readouterr().err
    assert "--frames '7:3': the animation has frames" in err and "text=" not in err
    assert main(["tradeoff", str(scenes / "ring.toml"), "-o", str(tmp_path / "none"), "--replot"]) == 2
    assert f"-o {tmp_path / 'none'}: no tradeoff.json there" in capsys.readouterr().err


def test_python_callers_read_the_parameters(tmp_path):
    from blockhash.errors import InputError
    from blockhash.evaluate.imagediff import compare_layers
    from blockhash.passes.frames import frame_range
    from blockhash.scene.loader import load_scene
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    with pytest.raises(InputError, match=r"export with drop_specular=True to write it"):
        export_mitsuba(load_scene(ROOT / "scenes" / "ring.toml"), tmp_path / "x")
    with pytest.raises(InputError, match=r"^text='7:3': the animation has frames 0 \.\. 4"):
        frame_range("7:3", 5)
    import numpy as np

    a = {"direct": np.zeros((4, 4, 3), np.float32)}
    with pytest.raises(InputError, match=r"^mask 'nope' is neither a layer"):
        compare_layers(a, a, mask="nope")
