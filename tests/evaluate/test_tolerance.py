"""Seed-to-seed noise of the ring scene and the limits it suggests (tiny renders)."""

import json
from pathlib import Path

import pytest

from blockhash.cli import main
from blockhash.errors import InputError
from blockhash.evaluate.tolerance import FLOORS, _round_up, seed_tolerances
from blockhash.scene.loader import load_scene

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

RING = Path(__file__).resolve().parents[2] / "scenes" / "ring.toml"
SETTINGS = dict(seeds=3, photons=4000, size=(32, 32), k=20)


@pytest.fixture(scope="module")
def report():
    return seed_tolerances(load_scene(RING), **SETTINGS)


@pytest.mark.slow
def test_the_caustic_changes_with_the_seed_and_the_direct_light_does_not(report):
    assert len(report.pairs["caustic"]["rms"]) == 3          # 3 seeds -> 3 pairs
    assert min(report.pairs["caustic"]["relative_rms"]) > 0.05
    assert max(report.pairs["direct"]["relative_rms"]) == 0
    assert report.spread["caustic"]["relative_mean"] > 0.05 and report.spread["direct"]["p95"] == 0
    assert report.spread_maps["caustic"].shape == (32, 32)


def test_proposals_are_the_largest_pair_times_the_margin_or_the_floor(report):
    for metric in ("rms", "relative_rms", "flip"):
        worst = max(report.pairs["caustic"][metric])
        assert report.proposed[metric]["caustic"] == pytest.approx(worst * 1.5)
    assert report.proposed["relative_rms"]["direct"] == FLOORS["relative_rms"]
    assert report.proposed["flip"]["direct"] == FLOORS["flip"]
    assert "--max-rel-rms caustic=" in report.options() and "--max-flip direct=0.001" in report.options()


def test_limits_round_up_to_two_digits():
    assert _round_up(0.2341) == "0.24" and _round_up(0.24) == "0.24" and _round_up(1e-4) == "0.0001"
    assert _round_up(0.0) == "0"


def test_too_few_seeds_or_a_margin_below_1_are_refused():
    ring = load_scene(RING)
    with pytest.raises(InputError, match="seeds=1: need at least 2 seeds"):
        seed_tolerances(ring, seeds=1)
    with pytest.raises(InputError, match="margin=0.5: .* must be >= 1"):
        seed_tolerances(ring, margin=0.5)


def test_the_command_line_names_its_flags_where_python_names_keywords(capsys):
    """The same refusal reads as the caller wrote it: ``seeds=1`` from Python, ``--seeds 1``
    from ``blockhash tolerance``."""
    from blockhash.cli import main

    assert main(["tolerance", str(RING), "--seeds", "1"]) == 2
    assert "--seeds 1: need at least 2 seeds" in capsys.readouterr().err


@pytest.mark.slow
def test_tolerance_command_prints_the_proposal_and_json(tmp_path, capsys):
    assert main(["tolerance", str(RING), "--seeds", "2", "--photons", "3000", "--size", "24x24",
                 "--k", "20", "--json", str(tmp_path / "t.json"),
                 "--heatmap", str(tmp_path / "spread.png")]) == 0
    out = capsys.readouterr().out
    assert "proposed: blockhash compare A.exr B.exr --max-rel-rms direct=0.0001" in out
    data = json.loads((tmp_path / "t.json").read_text())
    assert data["seeds"] == [0, 1] and data["proposed"]["flip"]["caustic"] > 0
    assert (tmp_path / "spread.png").is_file()
    assert main(["tolerance", "no/such.toml"]) == 2
