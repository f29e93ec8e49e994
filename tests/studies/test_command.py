"""The argument types and scene lookup that the commands in tools/ share."""

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from blockhash.studies.command import ToolParser, count, listing, side, size, timed, write_json

ROOT = Path(__file__).resolve().parents[2]
TOOL = str(ROOT / "tools" / "any_tool.py")


@pytest.mark.parametrize("text, value", [("200000", 200_000), ("200_000", 200_000), ("2e5", 200_000),
                                         ("1", 1)])
def test_a_count_reads_as_the_docs_write_it(text, value):
    assert count(text) == value


@pytest.mark.parametrize("text", ["0", "-3", "2.5", "1e400", "lots", ""])
def test_a_bad_count_names_the_value_and_the_form(text):
    with pytest.raises(argparse.ArgumentTypeError, match="whole number"):
        count(text)


def test_sizes_square_or_width_by_height():
    assert size("128") == (128, 128) and size("128x96") == (128, 96) and size("64X64") == (64, 64)
    assert side("256") == 256 and side("256x256") == 256
    with pytest.raises(argparse.ArgumentTypeError, match="square"):
        side("256x128")
    for bad in ("0", "ax3", "3x", "-2x2"):
        with pytest.raises(argparse.ArgumentTypeError):
            size(bad)


def test_lists_skip_empty_items():
    assert listing(count)("1,2e3,") == [1, 2000] and listing(count)("") == []


def test_a_scene_is_a_path_a_checkout_path_or_a_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # any working directory
    p = ToolParser("doc", TOOL)
    ring = (ROOT / "scenes" / "ring.toml").resolve()
    assert p.scene("ring") == ring and p.scene("scenes/ring.toml") == ring
    own = tmp_path / "mine.toml"
    own.write_text("")
    assert p.scene("mine.toml") == own.resolve()
    with pytest.raises(argparse.ArgumentTypeError, match=r"'nowhere': no such scene file; give a "
                       r"path or one of .*\bring\b"):
        p.scene("nowhere")


def test_the_shared_options_parse_and_refuse_by_name(capsys):
    p = ToolParser("doc", TOOL)
    p.scenes("ring,glass")
    p.photons(1000, many=True)
    p.size(128, many=True, flag="--sizes")
    p.json_output()
    args = p.parse_args(["--photons", "1e3,2e3", "--sizes", "32,48x48", "--json", "x.json"])
    assert [s.stem for s in args.scenes] == ["ring", "glass"]
    assert args.photons == [1000, 2000] and args.sizes == [32, 48] and args.json == Path("x.json")
    with pytest.raises(SystemExit):
        p.parse_args(["--photons", "many"])
    assert "argument --photons: 'many': expected a whole number" in capsys.readouterr().err


def test_timed_and_write_json(tmp_path):
    out, seconds = timed(sum, [1, 2, 3])
    assert out == 6 and seconds >= 0
    write_json(tmp_path / "a" / "b.json", {"x": np.float32(1.5), "v": np.arange(2), "p": tmp_path})
    assert json.loads((tmp_path / "a" / "b.json").read_text()) == {"x": 1.5, "v": [0, 1],
                                                                   "p": str(tmp_path)}
