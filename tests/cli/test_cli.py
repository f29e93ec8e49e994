"""The command line, end to end (blockhash.cli.main)."""

import argparse
from pathlib import Path

import numpy as np
import pytest

from blockhash.cli import main

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def test_index_command_builds_and_reports_accuracy(capsys):
    assert main(["index", "--photons", "20000", "--queries", "2000", "--k", "10"]) == 0
    out = capsys.readouterr().out
    assert "photons 20,000 in 2,000 blocks" in out
    assert "orphans 0 blocks" in out
    assert "accuracy: false negatives" in out


def test_index_command_reads_npy_positions(tmp_path, capsys):
    path = tmp_path / "photons.npy"
    np.save(path, np.random.default_rng(0).random((3000, 3)))
    assert main(["index", "--data", str(path), "--queries", "100", "--k", "1"]) == 0
    assert "photons: 3,000" in capsys.readouterr().out


def test_index_command_names_a_bad_data_argument(capsys):
    assert main(["index", "--data", "nowhere.npy"]) == 2
    err = capsys.readouterr().err
    assert "--data 'nowhere.npy': no such file" in err


def test_index_command_reports_bad_parameters(capsys):
    assert main(["index", "--photons", "100", "--k", "500", "--queries", "0"]) == 2
    assert "k=500 is out of range" in capsys.readouterr().err


def test_info_command_prints_renderer_and_limits(capsys):
    assert main(["info", "--backend", "egl"]) == 0
    out = capsys.readouterr().out
    assert "backend" in out and "GL_MAX_TEXTURE_SIZE" in out and "4.5" in out


def test_info_command_names_an_unavailable_backend(capsys, monkeypatch):
    import blockhash.gl.context as context

    def fail(name):
        raise OSError("library missing")

    monkeypatch.setattr(context, "_create", fail)
    monkeypatch.setattr(context, "_contexts", {})
    assert main(["info", "--backend", "osmesa"]) == 2
    err = capsys.readouterr().err
    assert "tried osmesa: library missing" in err and "libosmesa6" in err


def test_bench_command_prints_the_table_and_writes_json(tmp_path, capsys):
    out_json = tmp_path / "bench.json"
    assert main(["bench", "--photons", "5000", "--queries", "512", "--A", "2", "--repeat", "1",
                 "--no-kdtree", "--hashing", "--backend", "egl", "--json", str(out_json)]) == 0
    out = capsys.readouterr().out
    assert "cKDTree (CPU, all workers)" in out and "BH default" in out and "BH fetch-only floor" in out
    import json

    rows = json.loads(out_json.read_text())
    lookups = ("BH default", "BH default (Hilbert cells)", "BH default (tables hashed, walk off)")
    floors = ("BH fetch-only floor", "BH fetch-only floor (Hilbert cells)",
              "BH fetch-only floor (tables hashed, walk off)")
    assert {r["method"] for r in rows} == {"cKDTree (CPU, all workers)", *lookups, *floors,
                                           "cover gather (alone)"}
    by = {r["method"]: r for r in rows}
    assert by["cover gather (alone)"]["candidates"] >= by["cover gather (alone)"]["covering_mean"] > 0
    for name in lookups:  # each measured on its own
        assert 0 <= by[name]["fn_percent"] < 100 and by[name]["candidates"] > 0
    assert all(r["seconds"] > 0 for r in rows)
    gl_rows = [r for r in rows if r["method"] != "cKDTree (CPU, all workers)"]
    assert all(r["draws"] == 1 and r["gpu_min"] > 0 and r["wall_median"] > 0 for r in gl_rows)
    assert all(r["renderer"] and r["gl_version"] for r in rows)
    assert rows[0]["renderer"] in out


@pytest.mark.slow
def test_bench_times_the_caustic_pass_per_stage(tmp_path, capsys):
    out_json = tmp_path / "bench.json"
    scene = tmp_path / "ring.toml"  # the ring at 128 x 128: the stages' rows, in less time
    text = (SCENES / "ring.toml").read_text()
    assert "width = 512\nheight = 512" in text
    scene.write_text(text.replace("width = 512\nheight = 512", "width = 128\nheight = 128"))
    assert main(["bench", "--queries", "0", "--caustic", str(scene),
                 "--caustic-photons", "3000", "--repeat", "2", "--warmup", "1", "--backend", "egl",
                 "--caustic-estimates", "unbiased", "--json", str(out_json)]) == 0
    import json

    rows = json.loads(out_json.read_text())
    stages = ["fetch floor", "lookup", "lookup + estimate"]
    assert [(r["gather"], r["stage"]) for r in rows] == (
        [("cover", s) for s in stages] + [("walk", s) for s in stages]
        + [("walk", "lookup + estimate (unbiased)")] + [("cells", s) for s in stages]
        + [("kdtree", "lookup + estimate"), ("cpu", "lookup + estimate"),
           ("splat", "lookup + estimate")])
    assert 0.2 < rows[-1]["reach"] < 1.0  # the ring's mirror images are out of its reach
    shader = [r for r in rows if r["gather"] in ("cover", "walk", "cells")]
    assert all(r["draws"] == 2 and r["gpu_median"] > 0 and r["pixels"] == 128 * 128 for r in shader)
    assert all(r["draws"] == 2 and r["seconds"] > 0 for r in rows)
    assert "caustic pass (cover): lookup + estimate" in capsys.readouterr().out


def test_bench_names_an_unknown_estimate_before_tracing(capsys):
    assert main(["bench", "--queries", "0", "--caustic", str(SCENES / "ring.toml"),
                 "--caustic-estimates", "splat"]) == 2
    assert "estimate='splat' is not known" in capsys.readouterr().err


def test_bench_rejects_no_timed_draws(capsys):
    assert main(["bench", "--repeat", "0"]) == 2
    assert "--repeat 0" in capsys.readouterr().err


def test_flags_are_named_one_way_with_choices_from_one_list():
    from blockhash.cli import build_parser
    from blockhash.frame.options import METHODS
    from blockhash.gl.context import BACKENDS

    parser = build_parser()
    trade = parser.parse_args(["tradeoff", "scenes/ring.toml", "-o", "out", "--k", "16,50"])
    assert tuple(trade.ks) == (16, 50)
    assert parser.parse_args(["tradeoff", "scenes/ring.toml", "-o", "o", "--ks", "8"]).ks == (8,)
    assert parser.parse_args(["bench", "--variant", "paper"]).variants == "paper"
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, command in sub.choices.items():
        for action in command._actions:
            if "--backend" in action.option_strings:
                assert tuple(action.choices) == BACKENDS, name
            if "--method" in action.option_strings:
                assert set(action.choices) <= set(METHODS), name
                if name != "tradeoff":  # the sweep measures exact kNN ('kdtree') itself
                    assert tuple(action.choices) == METHODS, name


def test_tradeoff_takes_the_method_and_its_older_engine_spelling(capsys):
    from blockhash.cli import build_parser
    from blockhash.cli.tradeoff import METHOD_ENGINE

    parser = build_parser()
    args = ["tradeoff", "scenes/ring.toml", "-o", "o"]
    assert parser.parse_args(args).method is None
    assert parser.parse_args(args + ["--method", "cpu"]).method == "cpu"
    assert capsys.readouterr().err == ""
    assert parser.parse_args(args + ["--engine", "gl"]).method == "bh"
    assert "--engine gl is now --method bh" in capsys.readouterr().err
    assert parser.parse_args(args + ["--engine", "cpu"]).method == "cpu"
    assert METHOD_ENGINE == {"bh": "gl", "cpu": "cpu"}
    with pytest.raises(SystemExit):
        parser.parse_args(args + ["--method", "kdtree"])


@pytest.mark.parametrize("flags, engine", [([], "gl"), (["--method", "cpu"], "cpu"),
                                           (["--engine", "cpu"], "cpu"), (["--method", "bh"], "gl")])
def test_tradeoff_runs_its_sweep_on_the_engine_of_the_method(monkeypatch, tmp_path, flags, engine):
    import blockhash.studies.tradeoff.sweep as sweep
    from blockhash.errors import InputError

    seen = []

    def stop(scene, plan, **kw):
        seen.append(plan.engine)
        raise InputError("stopped before sweeping")

    monkeypatch.setattr(sweep, "run_sweep", stop)
    assert main(["tradeoff", str(SCENES / "ring.toml"), "-o", str(tmp_path), "--quick"] + flags) == 2
    assert seen == [engine]


def test_reference_command_with_the_light_tracer(tmp_path, capsys):
    from blockhash.evaluate.images import read_layers

    out = tmp_path / "glass.exr"
    assert main(["reference", str(SCENES / "glass.toml"), "--photons", "20000", "--spp", "1",
                 "--size", "24x24", "-o", str(out)]) == 0
    layers = read_layers(out)
    assert layers["caustic"].shape == (24, 24, 3) and layers["caustic"].max() > 0
    assert "light tracer" in capsys.readouterr().out
    assert main(["reference", str(SCENES / "glass.toml"), "--spp", "0", "-o", str(out)]) == 2


@pytest.mark.parametrize("command, words", [("export", ["--to", "--drop-specular", "DIR"]),
                                            ("reference", ["--engine", "mitsuba", "--spp"])])
def test_export_and_reference_have_help(command, words, capsys):
    with pytest.raises(SystemExit) as done:
        main([command, "--help"])
    assert done.value.code == 0
    out = capsys.readouterr().out
    assert all(w in out for w in words)
