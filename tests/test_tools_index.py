"""The index's study tools (accuracy, cell reads, cover gather, build time, shader variants),
each run on a tiny input from a folder outside the checkout, what it prints and writes
checked."""

import json
import math
import re
from pathlib import Path

import pytest
from conftest import run_tool

ROOT = Path(__file__).resolve().parents[1]

TINY = ["--photons", "3000", "--queries", "200"]


def rows_of(path):
    data = json.loads(path.read_text())
    assert data["command"].startswith("python tools/")
    return data["rows"]


def finite(row, *keys):
    return all(math.isfinite(row[key]) for key in keys)


def test_accuracy_by_k_tabulates_each_lookup_and_k(tmp_path):
    out = run_tool("accuracy_by_k.py", ["--maps", "uniform,ring", *TINY, "--k", "1,8",
                                        "--A", "64", "--lookups", "walk,cells",
                                        "--json", "out/rows.json"], tmp_path)
    rows = rows_of(tmp_path / "out" / "rows.json")
    assert len(rows) == 2 * 2 * 2
    assert {(r["lookup"], r["k"], r["map"]) for r in rows} == {
        (lookup, k, m) for lookup in ("walk", "cells") for k in (1, 8) for m in ("uniform", "ring")}
    assert all(0 <= r["fn_mean"] <= 1 and finite(r, "fn_near", "avg_dilation") for r in rows)
    walk = {(r["map"], r["k"]): r["fn_mean"] for r in rows if r["lookup"] == "walk"}
    assert walk[("uniform", 8)] < 0.05  # A = 64 finds nearly every neighbour
    assert "**walk, A = 64**" in out and "**cells, A = 64**" in out
    assert "| uniform | tune | " in out and "| ring | tune | " in out
    again = run_tool("accuracy_by_k.py", ["--from-json", "out/rows.json"], tmp_path)
    assert again.strip() == out[out.index("**walk"):].strip()


def test_small_k_sweeps_the_walk_floor(tmp_path):
    out = run_tool("small_k.py", ["--maps", "uniform", *TINY, "--k", "1,8", "--floors", "0,10",
                                  "--tables", "1,5"], tmp_path)
    lines = out.strip().splitlines()
    assert lines[0] == "false negatives (% of k) at A = 8, N = 3,000, 200 queries"
    table = {tuple(map(int, line.split()[1:3])): [float(c.rstrip("%")) for c in line.split()[3:]]
             for line in lines[2:]}
    assert sorted(table) == [(0, 1), (0, 5), (10, 1), (10, 5)]
    assert table[(0, 1)] == table[(0, 5)]  # no k below a floor of 0: the tables walked are moot
    assert table[(10, 5)][0] < table[(0, 1)][0]  # the floor helps k = 1
    assert all(0 <= v <= 100 for row in table.values() for v in row)


def test_cell_cover_bound_writes_shares_over_the_cap(tmp_path):
    out = run_tool("cell_cover_bound.py", ["--maps", "clustered", *TINY, "--k", "8",
                                           "--A", "8,64", "--cells", "27,125",
                                           "--json", "cover.json"], tmp_path)
    rows = rows_of(tmp_path / "cover.json")
    assert [(r["cells"], r["A"]) for r in rows] == [(27, 8), (27, 64), (125, 8), (125, 64)]
    assert len(re.findall(r"^clustered +cells<=", out, re.M)) == 4
    by = {(r["cells"], r["A"]): r for r in rows}
    for c in (27, 125):  # a larger cap leaves fewer queries over it
        assert by[(c, 64)]["over_near"] <= by[(c, 8)]["over_near"]
        assert by[(c, 64)]["over_far"] <= by[(c, 8)]["over_far"]
    for A in (8, 64):  # more cells allowed never read more
        assert by[(125, A)]["over_near"] <= by[(27, A)]["over_near"]
    assert 0 < rows[0]["far_share"] < 1 and rows[0]["median_bound_far"] >= 8


def test_eval_accuracy_writes_rows_markdown_and_reads_them_back(tmp_path):
    out = run_tool("eval_accuracy.py", ["--maps", "uniform,tilted@1e4", *TINY, "--k", "8",
                                        "--A", "8,64", "--ppb", "0.5,1", "--json", "acc.json",
                                        "--markdown", "acc.md"], tmp_path)
    data = json.loads((tmp_path / "acc.json").read_text())
    rows = data["rows"]
    assert data["machine"]["cpus"] >= 1
    # Per map: the default preset at each ppb and A, then the paper's (no sweep) at each A.
    assert len(rows) == 2 * (2 * 2 + 2)
    assert [r["config"] for r in rows[:6]] == [{"photons_per_bucket": 0.5}] * 2 + [
        {"photons_per_bucket": 1.0}] * 2 + [{}] * 2
    assert all(finite(r, "fn_mean", "avg_dilation", "candidates", "build_seconds") for r in rows)
    best = [r for r in rows if r["preset"] == "default" and r["A"] == 64 and r["map"] == "uniform"]
    assert best and all(r["fn_mean"] < 0.05 and r["avg_dilation"] > 1 - 1e-6 for r in best)
    table = (tmp_path / "acc.md").read_text()
    assert table.strip() in out and "| tilted@1e4 | report | paper |" in table
    again = run_tool("eval_accuracy.py", ["--from-json", "acc.json"], tmp_path)
    assert again.strip() == table.strip()


def test_cover_stats_reads_at_least_what_covers(tmp_path):
    run_tool("cover_stats.py", ["--scenes", "scenes/ring.toml", "--maps", "caustic",
                                "--photons", "3000", "--queries", "500", "--size", "16x16",
                                "--fine", "1,4", "--axis", "auto", "--json", "cs.json"], tmp_path)
    rows = rows_of(tmp_path / "cs.json")
    assert [(r["map"], r["fine_cells"]) for r in rows] == [
        ("ring", 1), ("ring", 4), ("caustic", 1), ("caustic", 4)]
    for r in rows:
        assert r["candidates_mean"] >= r["covering_mean"] > 0 and r["ratio"] >= 1
        assert r["octaves"] >= 1 and r["table_bytes_per_photon"] > 0
    # What covers a point is the radii's, not the layout's.
    assert rows[0]["covering_mean"] == rows[1]["covering_mean"]
    assert rows[2]["covering_mean"] == rows[3]["covering_mean"]
    assert rows[0]["queries"] <= 16 * 16 and rows[2]["queries"] == 500


def test_plane_queries_on_the_ring_floor(tmp_path):
    out = run_tool("plane_queries.py", ["scenes/ring.toml", "--photons", "3000",
                                        "--queries", "200", "--k", "8"], tmp_path)
    lines = out.strip().splitlines()
    assert lines[0].startswith("scenes/ring.toml: 3,000 photons, y in [0, 0], k=8, A=8")
    assert lines[1].split() == ["preset", "dy=0", "dy=1e-7", "dy=-1e-7", "dy=1e-3"]
    default, paper = (line.split() for line in lines[2:])
    assert default[0] == "default" and paper[0] == "paper" and len(default) == 5
    assert float(default[1].rstrip("%")) < 5  # the default finds its neighbours on the plane
    assert all(0 <= float(c.rstrip("%")) <= 100 for c in default[1:] + paper[1:])


def test_bench_build_times_the_index_beside_ckdtree(tmp_path):
    out = run_tool("bench_build.py", ["--maps", "caustic", "--photons", "2e3,3_000",
                                      "--A", "1,8", "--repeat", "2", "--json", "b.json"], tmp_path)
    rows = rows_of(tmp_path / "b.json")
    assert [(r["photons"], r["A"]) for r in rows] == [(2000, 1), (2000, 8), (3000, 1), (3000, 8)]
    for r in rows:
        assert r["build_s"] > 0 and r["ckdtree_s"] > 0
        assert r["ratio"] == pytest.approx(r["build_s"] / r["ckdtree_s"])
        assert set(r["stages"]) == {"encode", "blocks", "thresholds", "insert", "pack"}
        assert sum(r["stages"].values()) <= 2 * r["build_s"]
    assert len(re.findall(r"^caustic +[23],000 +[18] ", out, re.M)) == 4


@pytest.mark.gl
def test_bench_variants_times_two_specs(tmp_path):
    out = run_tool("bench_variants.py", ["--photons", "3000", "--queries", "256", "--k", "8",
                                         "--rounds", "2", "binary-branch-on-packed",
                                         "floor:binary-set-on-packed@8"], tmp_path)
    lines = out.strip().splitlines()
    assert "3,000 photons (caustic), 256 image-raster queries, k=8, A=8" in lines[0]
    assert lines[1].startswith("spec") and "(wall time, 2 rounds)" in lines[1]
    first, floor = (line.split() for line in lines[2:])
    assert first[0] == "binary-branch-on-packed" and first[3] == "1.00"
    assert floor[0] == "floor:binary-set-on-packed@8"
    assert all(float(v) > 0 for v in first[1:3] + floor[1:4])


def test_photon_kernels_times_each_stage_beside_a_baseline_on_the_same_photons(tmp_path):
    out = tmp_path / "kernels.json"
    text = run_tool("photon_kernels.py", ["--baseline", ROOT, "--scenes", "ring",
                                          "--photons", "3000", "--repeat", "1", "--json", out],
                    tmp_path)
    [row] = json.loads(out.read_text())["rows"]
    for side in ("baseline", "this"):
        assert all(row[side]["seconds"][s] > 0 for s in ("encode", "index", "radii", "cover build"))
    # the same checkout on both sides builds the same records, radii and gather
    assert row["same"] == ["records", "radii", "gather"]
    assert "| ring | 3,000 |" in text and text.rstrip().endswith("| records, radii, gather |")
