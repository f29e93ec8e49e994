"""The commands in tools/ that measure a render in passes, or hold it to Mitsuba 3, run on a
tiny input from a folder outside the checkout: what each prints and writes.

The ones that run Mitsuba skip without it, unless BLOCKHASH_REQUIRE_MITSUBA is set, where
they fail instead."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import mitsuba_or_skip, run_tool

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def needs_mitsuba():
    mitsuba_or_skip()


def table_rows(text: str, first: str) -> list[list[str]]:
    """The cells of the Markdown table rows of ``text`` that start with ``| first |``."""
    return [[c.strip() for c in line.split("|")[1:-1]] for line in text.splitlines()
            if line.startswith(f"| {first} |")]


def test_mitsuba_agreement_prints_a_flux_ratio_near_one(tmp_path, needs_mitsuba):
    text = run_tool("mitsuba_agreement.py", ["--scenes", "ring", "--size", "24", "--spp", "16",
                                              "--photons", "2e5"], tmp_path)
    [row] = table_rows(text, "ring")
    ratio = [float(v) for v in row[1].split(",")]
    assert all(0.8 < r < 1.25 for r in ratio), ratio  # the same caustic, two renderers
    assert 0 < float(row[2]) < 0.1  # the light tracer's flux noise
    assert math.isfinite(float(row[3]))


@pytest.mark.gl
def test_mitsuba_mirror_finds_the_caustic_in_the_mirror_only_in_blockhash(tmp_path, needs_mitsuba):
    out = tmp_path / "mirror.json"
    text = run_tool("mitsuba_mirror.py", ["--size", "48", "--spp", "16", "--photons", "5000",
                                           "--passes", "1", "--png-dir", "images", "--json", out],
                    tmp_path)
    res = json.loads(out.read_text())
    assert res["scene"] == "scenes/mirror.toml" and res["photons"] == 5000
    bh, ptracer, path = res["rows"]
    assert sum(bh["mirror"]) > 0 and sum(bh["floor"]) > 0
    assert sum(ptracer["mirror"]) == 0  # a particle tracer cannot see a caustic in a mirror
    assert sum(ptracer["floor"]) > 0
    assert res["identity"]["pixels"] > 0
    assert all(0.5 < r < 1.5 for r in res["identity"]["ratio"])
    for name in ("mirror", "mirror-mitsuba-ptracer", "mirror-mitsuba-path"):
        assert (tmp_path / "images" / f"{name}.png").stat().st_size > 0
    assert "| blockhash caustic layer |" in text


@pytest.mark.gl
def test_glass_speckle_prints_the_direct_layers_error_against_more_samples(tmp_path):
    text = run_tool("glass_speckle.py", ["--scene", "glass", "--size", "24", "--spp-ref", "16",
                                         "--one-branch"], tmp_path)
    lines = [line for line in text.splitlines() if line.startswith("24 x 24")]
    assert [line.split(", ")[2].split(":")[0] for line in lines] == ["both branches",
                                                                       "one branch"]
    for line in lines:
        errors = [float(w.rstrip(",")) for w in line.split() if w[0].isdigit() and "." in w]
        assert len(errors) == 3 and all(0 < e < 1 for e in errors), line


@pytest.mark.gl
def test_mirror_identity_holds_on_a_small_image(tmp_path):
    out = tmp_path / "identity.json"
    text = run_tool("mirror_identity.py", ["mirror", "--size", "48", "--photons", "5000",
                                           "--spp", "1", "--seeds", "1,2", "--json", out],
                    tmp_path)
    res = json.loads(out.read_text())
    assert res["scene"] == "scenes/mirror.toml" and res["pixels"] > 0
    direct = res["layers"]["direct"]
    assert direct["holds"] and res["layers"]["caustic"]["holds"]
    assert len(direct["runs"]) == 2  # one run a seed
    assert all(abs(r - 1) < 0.05 for run in direct["runs"] for r in run["ratio"])
    assert text.startswith("scenes/mirror.toml, 48 x 48, 5,000 photons, 1 spp")


@pytest.mark.gl
def test_pass_convergence_writes_a_row_per_pass_count(tmp_path, needs_mitsuba):
    out, cache = tmp_path / "convergence.json", tmp_path / "cache"
    text = run_tool("pass_convergence.py", ["--scenes", "ring", "--size", "24", "--seeds", "2",
                                            "--passes", "2", "--photons", "3000", "--ref-spp",
                                            "16", "--cache", cache, "--json", out], tmp_path)
    [res] = json.loads(out.read_text())
    assert res["scene"] == "ring" and res["seeds"] == 2
    assert [r["passes"] for r in res["rows"]] == [1, 2]
    for r in res["rows"]:
        assert 0.7 < r["flux_of_mean"] < 1.4  # the reference's flux, at 16 spp
        assert 0 < r["blur_of_mean"] < 2 and 0 < r["blur_one_median"] < 2
    assert math.isfinite(res["power_law_blur_of_mean"])
    assert (cache / "ring-24-16-albedo1024.npy").is_file()
    assert len(table_rows(text, "ring")) == 3


@pytest.mark.gl
def test_time_to_error_writes_the_curve_and_mitsubas_ladder(tmp_path, needs_mitsuba):
    out = tmp_path / "tte.json"
    text = run_tool("time_to_error.py", ["--scenes", "ring", "--size", "24", "--times", "30",
                                         "--passes", "2", "--photons", "3000", "--ref-spp", "16",
                                         "--max-spp", "2", "--cache", tmp_path / "cache",
                                         "--integrators", "ptracer,path", "--json", out], tmp_path)
    row, path_row = json.loads(out.read_text())
    assert (row["integrator"], path_row["integrator"]) == ("ptracer", "path")
    assert path_row["curve"] == row["curve"]  # one blockhash curve, raced by both
    assert [r["spp"] for r in path_row["ladder"]] == [1, 2]
    assert [c["passes"] for c in row["curve"]] == [1, 2]
    assert all(0.7 < c["flux"] < 1.4 and c["blur"] > 0 for c in row["curve"])
    assert [r["spp"] for r in row["ladder"]] == [1, 2]
    assert row["one_pass"]["spp"] == 9 and row["one_pass"]["blur"] > 0
    [at] = row["at"]
    assert at["time"] == 30 and at["passes"] == 2
    assert row["stored"] > 1000
    assert "| ring | 24 | ptracer | 30 (" in text and "| ring | 24 | path | 30 (" in text
    assert "the faster Mitsuba's time" in text
    again = run_tool("time_to_error.py", ["--from-json", out], tmp_path)
    assert again.strip() and again.strip() in text  # the tables again, from the JSON


@pytest.mark.gl
def test_pass_stages_writes_each_stage_beside_a_baseline(tmp_path):
    out = tmp_path / "stages.json"
    text = run_tool("pass_stages.py", ["--baseline", ROOT, "--scenes", "ring",
                                       "--sizes", "24", "--photons", "2000", "--passes", "1",
                                       "--json", out], tmp_path)
    [row] = json.loads(out.read_text())["rows"]
    for side in ("baseline", "this"):
        assert row[side]["stored"] > 1000 and row[side]["seconds"]["trace"] > 0
        assert row[side]["stored_per_s"] > 0
    # the same checkout on both sides: the same photons, whatever the seconds
    assert row["baseline"]["stored"] == row["this"]["stored"]
    assert "| ring | 24 | 2,000 | speed-up |" in text


@pytest.mark.gl
def test_pass_memory_writes_the_peaks_of_each_pass_count(tmp_path):
    text = run_tool("pass_memory.py", ["--photons", "2000", "--passes", "1,2",
                                       "--size", "24", "--marks", "1,2"], tmp_path)
    rows = table_rows(text, "default")
    assert [r[1] for r in rows] == ["1", "2"]
    assert [len(r[6].split(",")) for r in rows] == [1, 2]  # the peaks after passes 1 and 2
    peak = float(rows[-1][3])
    assert 50 < peak < 5000  # MiB: a real process's resident set


@pytest.mark.gl
def test_pass_memory_gives_the_bytes_a_stored_photon_between_photon_counts(tmp_path):
    text = run_tool("pass_memory.py", ["--photons", "2000,6000", "--passes", "1",
                                       "--size", "24", "--overlap", "off"], tmp_path)
    assert [r[2] for r in table_rows(text, "default")[:2]] == ["2,000", "6,000"]
    slope = [line for line in text.splitlines() if "2,000 -> 6,000" in line]
    assert len(slope) == 1 and "(1 in flight)" in text
    per_photon = float(slope[0].split("|")[4])
    assert -10_000 < per_photon < 10_000  # bytes: 4,000 photons move the peak by little


@pytest.mark.gl
def test_light_kinds_measures_each_kind_and_holds_two_to_mitsuba(tmp_path, needs_mitsuba):
    out = tmp_path / "lights.json"
    text = run_tool("light_kinds.py", ["--photons", "5000", "--size", "24", "--passes", "2",
                                       "--pass-photons", "3000", "--ref-spp", "16",
                                       "--png-dir", tmp_path / "png", "--json", out], tmp_path)
    res = json.loads(out.read_text())
    kinds = {k["scene"]: k for k in res["kinds"]}
    assert {s: k["lights"] for s, k in kinds.items()} == {
        "ring": ["PointLight"], "cbox": ["AreaLight"], "sun": ["DirectionalLight"]}
    for k in kinds.values():
        assert k["stored"] == 5000 and 0.3 < k["stored_fraction"] <= 1.0
        assert k["stored_per_second"] > 0
    rows = {r["scene"]: r for r in res["agreement"]}
    assert set(rows) == {"cbox", "sun"}
    for r in rows.values():
        assert 0.6 < r["caustic_flux"] < 1.5  # a tiny render against a 16 spp Mitsuba
        assert 0.97 < r["direct"]["ratio"] < 1.03  # direct light: no photon noise
        assert r["direct"]["passes"] == [4, 64]
        e4, e64 = r["direct"]["rel_rms"]
        assert e64 < e4
    import OpenImageIO as oiio

    for name in ("cbox", "cbox-mitsuba", "sun", "sun-mitsuba"):
        img = oiio.ImageInput.open(str(tmp_path / "png" / f"{name}.png"))
        pixels = img.read_image(format="uint8")
        img.close()
        assert pixels.shape == (24, 24, 3) and pixels.max() > 100, name  # lit, not black
    assert len(table_rows(text, "cbox")) == 2 and len(table_rows(text, "sun")) == 2


@pytest.mark.gl
def test_whole_image_holds_the_indirect_layer_to_mitsuba_and_the_light_tracer(tmp_path, needs_mitsuba):
    out = tmp_path / "whole.json"
    text = run_tool("whole_image.py", ["--scenes", "corner,glass", "--size", "24", "--passes", "1",
                                       "--photons", "30000", "--ref-spp", "256",
                                       "--lt-photons", "100000", "--json", out], tmp_path)
    rows = {r["scene"]: r for r in json.loads(out.read_text())}
    corner, glass = rows["corner"], rows["glass"]
    # corner's wall and floor light each other: the indirect layer brings the image up to
    # Mitsuba's (a tiny render against a 16 spp reference); glass has no such light
    assert 0.9 < corner["flux"] < 1.15 and corner["flux"] - corner["flux_without"] > 0.05, corner
    assert 0.8 < corner["indirect_vs_light_tracer"] < 1.3  # 900 photons: wide discs
    assert "indirect_vs_light_tracer" not in glass and glass["indirect_note"].startswith("none")
    assert glass["flux"] == glass["flux_without"]
    assert len(table_rows(text, "corner")) == 1


@pytest.mark.gl
def test_time_to_error_races_the_whole_image(tmp_path, needs_mitsuba):
    out = tmp_path / "whole.json"
    text = run_tool("time_to_error.py", ["--scenes", "corner", "--size", "24", "--times", "30",
                                         "--passes", "2", "--photons", "3000", "--ref-spp", "16",
                                         "--max-spp", "2", "--cache", tmp_path / "cache",
                                         "--layer", "whole", "--integrators", "ptracer,path",
                                         "--json", out], tmp_path)
    rows = json.loads(out.read_text())
    assert [r["layer"] for r in rows] == ["whole", "whole"]
    assert all(0.6 < c["flux"] < 1.5 for c in rows[0]["curve"])  # the whole image's light
    assert all(0 <= c["flip"] <= 1 for c in rows[0]["curve"])  # LDR-FLIP
    assert (tmp_path / "cache" / "corner-24-16-whole.npy").is_file()
    assert "| corner | 24 | path | 30 (" in text


def test_frames_bench_child_imports_only_what_a_baseline_checkout_has():
    """The latency child runs on a baseline checkout's package: it imports neither this tool
    nor the study helpers (a baseline from before them lacked them), only the scene, the
    passes and the standard library's and numpy's modules."""
    import ast
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "tools" / "frames_bench.py"
    spec = importlib.util.spec_from_file_location("frames_bench_under_test", path)
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    names = set()
    for node in ast.walk(ast.parse(tool.CHILD)):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            names.add(node.module)
    assert {"blockhash.scene.animation", "blockhash.passes.session"} <= names
    allowed = ("blockhash.scene.", "blockhash.passes.", "numpy", "json", "math", "sys", "time",
               "dataclasses")
    assert all(n.startswith(allowed) for n in names), sorted(names)


@pytest.mark.gl
def test_frames_bench_times_frames_flicker_and_memory(tmp_path):
    out = tmp_path / "frames.json"
    root = Path(__file__).resolve().parents[1]
    text = run_tool("frames_bench.py", ["--scenes", "ring", "--sizes", "32", "--spp", "1",
                                        "--baseline", root,
                                        "--frames", "3", "--photons", "3000", "--flicker-frames", "3",
                                        "--degrees", "1",
                                        "--flicker-size", "32", "--flicker-photons", "20000",
                                        "--reference-photons", "100000", "--memory-frames", "1,2",
                                        "--memory-size", "32", "--memory-photons", "3000",
                                        "--json", out], tmp_path)
    res = json.loads(out.read_text())
    motions = {(r["motion"], r["commit"]): r for r in res["latency"]}
    assert set(motions) == {(m, c) for m in ("camera orbit", "light circling")
                            for c in ("this", "baseline")}
    assert all(r["frame"] > 0 and 0 < r["gather"] < r["frame"] and r["fps"] == 1 / r["frame"]
               for r in motions.values())
    [f] = res["flicker"]
    assert f["common"] > 0 and f["independent"] > 0 and f["ratio"] == f["independent"] / f["common"]
    assert [m["frames"] for m in res["memory"]] == [1, 2] and res["memory"][0]["peak_bytes"] > 2**20
    assert all(0 < m["resident_bytes"] <= m["peak_bytes"] for m in res["memory"])
    assert len(table_rows(text, "ring")) == 4
    assert text.count("| this / baseline |") == 2


@pytest.mark.gl
def test_profile_frames_prints_the_frames_seconds_and_their_functions(tmp_path):
    text = run_tool("profile_frames.py", ["ring", "--size", "24", "--photons", "3000",
                                          "--frames", "2", "--top", "5"], tmp_path)
    assert text.startswith("seconds a frame: 1: ")
    assert "render_frames" in text and "cumulative" in text


@pytest.mark.gl
def test_stage_memory_gives_each_stage_beside_a_baseline(tmp_path):
    out = tmp_path / "stages.json"
    text = run_tool("stage_memory.py", ["--baseline", ROOT, "--scenes", "ring", "--size", "24",
                                        "--photons", "3000", "--json", out], tmp_path)
    rows = table_rows(text, "ring")
    assert [r[1] for r in rows] == ["baseline", "this"]
    res = json.loads(out.read_text())["rows"][0]
    # the same checkout on both sides: the same photons; every stage measured
    assert res["baseline"]["stored"] == res["this"]["stored"] > 0
    assert set(res["this"]["stages"]) == {"trace", "index", "photon radii", "pixel splat",
                                          "cover gather", "estimate"}


@pytest.mark.gl
def test_gpu_conformance_holds_the_gl_image_to_the_cpu_reference_in_strict_gl(tmp_path):
    out = tmp_path / "conformance.json"
    text = run_tool("gpu_conformance.py", ["--scenes", "cbox,mirror", "--size", "24",
                                           "--photons", "5000", "--strict", "--box-size", "24",
                                           "--box-passes", "2", "--box-workers", "1",
                                           "--json", out], tmp_path)
    assert "strict GL" in text.splitlines()[0]
    data = json.loads(out.read_text())
    assert {r["layer"] for r in data["rows"] if r["scene"] == "cbox"} == {
        "direct", "caustic", "indirect", "combined"}
    assert all(r["ok"] and r["gl_finite"] and r["over"] == 0 for r in data["rows"])
    assert data["box"]["ok"] and data["box"]["non_finite"]["indirect"] == 0


def test_gpu_conformance_counts_values_beyond_tolerance_and_non_finite_ones():
    import importlib.util

    spec = importlib.util.spec_from_file_location("gpu_conformance", ROOT / "tools" / "gpu_conformance.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    cpu = np.ones((4, 4, 3))
    assert tool.compare(cpu.astype(np.float32), cpu)["ok"]
    off = cpu.copy()
    off[1, 1, 1] = 1.001
    assert tool.compare(off, cpu)["over"] == 1
    off[0, 0, 0] = np.nan
    row = tool.compare(off, cpu)
    assert not row["gl_finite"] and not row["ok"]


@pytest.mark.gl
def test_device_pass_writes_each_process_count_on_the_host_tracer(tmp_path):
    out = tmp_path / "device.json"
    text = run_tool("device_pass.py", ["--scenes", "ring", "--size", "16", "--photons", "3000",
                                       "--passes", "2", "--workers", "0", "--device", "host",
                                       "--json", out], tmp_path)
    [row] = json.loads(out.read_text())["rows"]
    assert (row["scene"], row["workers"], row["passes"], row["device"]) == ("ring", 0, 2, "host")
    assert row["stored"] > 5000 and row["photon_stages_s"] > 0 and row["wall_s"] > 0
    assert "| ring | 1 (in process) | 2 | host |" in text
