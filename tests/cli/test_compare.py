"""`blockhash compare` as a CI step: exit 0 within the limits, 1 beyond, 2 on bad input."""

import json

import numpy as np
import OpenImageIO as oiio
import pytest

from blockhash.cli import main
from blockhash.evaluate.images import write_exr


@pytest.fixture
def pair(tmp_path):
    """b.exr and a.exr whose caustic layer is 10 % brighter (relative RMS 0.1)."""
    rng = np.random.default_rng(0)
    b = {"direct": rng.random((16, 24, 3)).astype(np.float32),
         "caustic": rng.random((16, 24, 3)).astype(np.float32)}
    a = {"direct": b["direct"], "caustic": b["caustic"] * 1.1}
    write_exr(tmp_path / "a.exr", a)
    write_exr(tmp_path / "b.exr", b)
    return str(tmp_path / "a.exr"), str(tmp_path / "b.exr")


def test_within_the_limits_exits_0(pair, capsys):
    assert main(["compare", *pair, "--max-rel-rms", "0.11", "--max-flip", "0.5"]) == 0
    out = capsys.readouterr().out
    assert "caustic" in out and "FLIP" in out and "pass: every layer within its limits" in out


def test_a_layer_beyond_its_limit_exits_1_and_says_which(pair, capsys):
    assert main(["compare", *pair, "--max-rel-rms", "0.05"]) == 1
    err = capsys.readouterr().err
    assert "FAIL layer 'caustic': relative_rms 0.1 > 0.05 (--max-rel-rms, 2x the limit)" in err
    assert "'direct'" not in err


def test_a_per_layer_limit_applies_to_that_layer_only(pair, capsys):
    assert main(["compare", *pair, "--max-rel-rms", "0", "--max-rel-rms", "caustic=0.2"]) == 0
    assert main(["compare", *pair, "--max-rms", "direct=0", "--max-flip", "caustic=0"]) == 1
    assert "layer 'caustic': flip" in capsys.readouterr().err


def test_json_goes_to_stdout_alone_or_to_a_file(pair, tmp_path, capsys):
    assert main(["compare", *pair, "--max-rel-rms", "0.05", "--json", "-"]) == 1
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    assert report["passed"] is False and "relative rms" in captured.err
    assert report["failures"] == [{"layer": "caustic", "metric": "relative_rms",
                                   "value": pytest.approx(0.1, rel=1e-5), "limit": 0.05}]
    assert report["layers"]["direct"]["rms"] == 0
    assert main(["compare", *pair, "--json", str(tmp_path / "r.json")]) == 0
    assert json.loads((tmp_path / "r.json").read_text())["limits"] == {}


def test_mask_compares_only_where_the_layer_is_non_zero(tmp_path, capsys):
    rng = np.random.default_rng(1)
    b = {"direct": rng.random((16, 16, 3)).astype(np.float32),
         "caustic": np.zeros((16, 16, 3), np.float32)}
    b["caustic"][:8] = 1.0
    a = {"direct": b["direct"].copy(), "caustic": b["caustic"]}
    a["direct"][8:] += 1.0  # only where the caustic is black
    write_exr(tmp_path / "a.exr", a)
    write_exr(tmp_path / "b.exr", b)
    args = ["compare", str(tmp_path / "a.exr"), str(tmp_path / "b.exr"), "--max-rms", "1e-6"]
    assert main(args) == 1
    assert main(args + ["--mask", "caustic"]) == 0
    assert "mask: 128 of 256 pixels" in capsys.readouterr().out


@pytest.mark.slow
def test_heatmap_and_strip_are_written(pair, tmp_path, capsys):
    heat, strip = tmp_path / "heat.png", tmp_path / "strip.png"
    assert main(["compare", *pair, "--heatmap", str(heat), "--strip", str(strip),
                 "--error", "abs"]) == 0
    for path in (heat, strip):
        spec = oiio.ImageInput.open(str(path)).spec()
        assert spec.width > 300 and spec.height > 200
    out = capsys.readouterr().out
    assert f"heat map, abs error: {heat}" in out and f"strip (A | B | error), abs error: {strip}" in out


def test_missing_file_exits_2_naming_it(pair, tmp_path, capsys):
    assert main(["compare", pair[0], str(tmp_path / "gone.exr")]) == 2
    err = capsys.readouterr().err
    assert "gone.exr: no such image file" in err and "Traceback" not in err


def test_different_sizes_or_layers_exit_2(pair, tmp_path, capsys):
    write_exr(tmp_path / "small.exr", {"direct": np.zeros((8, 8, 3)), "caustic": np.zeros((8, 8, 3))})
    assert main(["compare", pair[0], str(tmp_path / "small.exr")]) == 2
    assert "a.exr is 24x16 but" in capsys.readouterr().err
    write_exr(tmp_path / "one.exr", {"direct": np.zeros((16, 24, 3))})
    assert main(["compare", pair[0], str(tmp_path / "one.exr")]) == 2
    assert "have different layers" in capsys.readouterr().err


def test_a_limit_for_an_unknown_layer_exits_2(pair, capsys):
    assert main(["compare", *pair, "--max-flip", "shadow=0.1"]) == 2
    assert "--max-flip names layer(s) ['shadow']" in capsys.readouterr().err


@pytest.mark.parametrize("value, why", [("big", "expected a number or LAYER=NUMBER"),
                                        ("caustic=-1", "must be a number >= 0")])
def test_a_malformed_limit_exits_2(pair, capsys, value, why):
    with pytest.raises(SystemExit) as exc:
        main(["compare", *pair, "--max-rms", value])
    assert exc.value.code == 2 and why in capsys.readouterr().err


def test_an_unwritable_json_path_exits_2(pair, tmp_path, capsys):
    assert main(["compare", *pair, "--json", str(tmp_path / "no" / "r.json")]) == 2
    assert "r.json: cannot write it (No such file or directory)" in capsys.readouterr().err


def test_json_spells_infinite_values_as_strings(tmp_path, capsys):
    write_exr(tmp_path / "a.exr", {"rgb": np.ones((4, 4, 3))})
    write_exr(tmp_path / "b.exr", {"rgb": np.zeros((4, 4, 3))})
    assert main(["compare", str(tmp_path / "a.exr"), str(tmp_path / "b.exr"), "--json", "-",
                 "--max-rel-rms", "1"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["layers"]["rgb"]["relative_rms"] == "inf"
    assert report["failures"][0]["value"] == "inf"


def test_an_unwritable_heatmap_path_exits_2(pair, tmp_path, capsys):
    assert main(["compare", *pair, "--heatmap", str(tmp_path / "no" / "h.png")]) == 2
    assert "directory" in capsys.readouterr().err
