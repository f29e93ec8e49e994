"""Settings for a budget (blockhash.studies.tradeoff.budget) from a synthetic trade study."""

from __future__ import annotations

import json

import pytest

from blockhash.cli import main
from blockhash.errors import InputError
from blockhash.studies.tradeoff.budget import choose, predicted_seconds, study_for

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)


def row(n, A, seconds, error, preset="default"):
    return {"method": "bh", "photons": n, "k": 50, "A": A, "preset": preset, "variant": "default",
            "seconds": {"trace": seconds / 2, "index_build": 0.0, "caustic_pass": seconds / 2},
            "rel_rms_reference_blur": error}


STUDY = {"scene": "s.toml", "size": [10, 10], "plan": {"supersample": 1},
         "rows": [row(1_000, 8, 1.0, 0.30), row(10_000, 8, 2.0, 0.10), row(10_000, 1, 1.5, 0.50),
                  row(100_000, 8, 6.0, 0.05), row(100_000, 4, 5.0, 0.07),
                  row(100_000, 64, 0.1, 0.0, preset="paper")]}


def test_time_budget_picks_the_least_error_that_fits():
    c = choose(STUDY, pixels=100, time_budget=5.5)
    assert (c.photons, c.A) == (100_000, 4) and c.predicted_error == 0.07
    assert "least error" in c.reason


def test_target_error_picks_the_fastest_setting_that_reaches_it():
    c = choose(STUDY, pixels=100, target_error=0.2)
    assert (c.photons, c.A) == (10_000, 8)


def test_pass_time_scales_with_the_pixels():
    assert predicted_seconds(STUDY["rows"][0], STUDY, 400) == pytest.approx(0.5 + 0.5 * 4)


def test_impossible_requests_name_the_parameter():
    with pytest.raises(InputError, match="time_budget=0.1 s: no measured setting fits"):
        choose(STUDY, pixels=100, time_budget=0.1)
    with pytest.raises(InputError, match="target_error=0.01: no measured setting reaches it"):
        choose(STUDY, pixels=100, target_error=0.01)
    with pytest.raises(InputError, match="exactly one"):
        choose(STUDY, pixels=100)


def test_an_explicit_study_file_is_read_and_a_missing_one_named(tmp_path):
    path = tmp_path / "tradeoff.json"
    path.write_text(json.dumps(STUDY))
    assert study_for(None, cache_dir=tmp_path, study_path=path)["size"] == [10, 10]
    with pytest.raises(InputError, match="study_path=.*nope.json: no such file"):
        study_for(None, cache_dir=tmp_path, study_path=tmp_path / "nope.json")


def test_a_scene_without_mirrors_skips_the_photon_stages(tmp_path, capsys):
    from pathlib import Path

    ring = Path(__file__).resolve().parents[3] / "scenes" / "ring.toml"
    text = ring.read_text().replace('material = "mirror"', 'material = "floor"')
    scene = tmp_path / "plain.toml"
    scene.write_text(text)
    code = main(["render", str(scene), "--size", "16x16", "--time-budget", "1",
                 "-o", str(tmp_path / "plain.exr"), "--cache", str(tmp_path)])
    assert code == 0
    captured = capsys.readouterr()
    out = captured.out
    assert "the scene has no specular object" in captured.err
    assert "no caustic photons are traced" in out
    assert "photons stored: 0" in out
    assert not any(tmp_path.glob("tradeoff-*.json"))  # no calibration was run
