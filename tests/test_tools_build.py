"""The tools that make the checkout's generated files and references, and measure builds and
compilers, each run on a tiny input from a folder outside the checkout: what they write
agrees with what is committed (the merge networks, the reference image) or holds the figures
they promise (cold and warm starts, the trade study, the GPU compiler's statistics, the GPU
benchmark's rehearsal)."""

import importlib.util
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import TOOLS_DIR, mitsuba_or_skip, run_tool

from blockhash.evaluate.images import read_attribute, read_layers
from blockhash.evaluate.testing import assert_images_close

ROOT = TOOLS_DIR.parent


def test_gen_merge_network_writes_the_committed_file(tmp_path):
    out = tmp_path / "bh_merge_net.glsl"
    text = run_tool("gen_merge_network.py", ["--out", out], tmp_path)
    assert text.strip() == f"wrote {out}"
    assert out.read_text() == (ROOT / "glsl" / "bh_merge_net.glsl").read_text()
    assert "void bh_sort_batch()" in out.read_text()
    # --check compares and writes nothing: the committed file is current, a changed one is not
    assert "is current" in run_tool("gen_merge_network.py", ["--check"], tmp_path)
    out.write_text(out.read_text().replace("BH_MX_B(0, 1)", "BH_MX_B(1, 0)", 1))
    stale = subprocess.run([sys.executable, str(TOOLS_DIR / "gen_merge_network.py"), "--check",
                            "--out", str(out)], cwd=tmp_path, capture_output=True, text=True)
    assert stale.returncode == 1 and "not current" in stale.stdout
    assert "BH_MX_B(1, 0)" in out.read_text()


def _reference_limits():
    """The noise limits tests/frame/test_reference_images.py holds the reference to."""
    path = ROOT / "tests" / "frame" / "test_reference_images.py"
    spec = importlib.util.spec_from_file_location("reference_images", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.LIMITS


@pytest.mark.gl
def test_regenerate_references_renders_one_reference_elsewhere(tmp_path):
    """One reference into a folder of its own: the committed file's direct light to float32's
    last bits (it does not depend on the photons; another CPU's vector width and fused
    multiply-adds move a value by an ulp: 3.4e-7 at most, measured; the camera's rays cast on
    a Dr.Jit device, hit points in float32 where embree's host casts interpolate in float64,
    by a few parts in 10^6: 2.3e-6 at most, measured), its caustic within the photon noise
    the test allows."""
    text = run_tool("regenerate_references.py", ["ring-48x48", "--out", tmp_path / "refs"],
                    tmp_path)
    new, committed = tmp_path / "refs" / "ring-48x48.exr", ROOT / "tests" / "data" / "ring-48x48.exr"
    assert text.strip() == f"wrote {new}"
    assert sorted(p.name for p in (tmp_path / "refs").iterdir()) == ["ring-48x48.exr"]
    layers, reference = read_layers(new), read_layers(committed)
    assert layers["direct"].shape == (48, 48, 3) and layers["caustic"].sum() > 0
    np.testing.assert_allclose(layers["direct"], reference["direct"], rtol=1e-5, atol=0.0)
    assert read_attribute(new, "blockhash:spp") == read_attribute(committed, "blockhash:spp") == 9
    assert_images_close(layers, committed, **_reference_limits(), out_dir=tmp_path)


@pytest.mark.gl
def test_cold_start_times_a_cold_and_a_warm_process(tmp_path):
    out = tmp_path / "cold.json"
    text = run_tool("cold_start.py", ["ring", "--size", "16x16", "--photons", "1000",
                                      "--repeat", "1", "--json", out], tmp_path)
    assert text.startswith("blockhash render scenes/ring.toml --size 16x16 --photons 1000: "
                           "1 pairs, cold then warm")
    figures = json.loads(out.read_text())
    (cold_s, cold), (warm_s, warm) = figures["runs"]["cold"][0], figures["runs"]["warm"][0]
    assert 0 < warm_s and 0 < cold_s and figures["ratios"] == [cold_s / warm_s]
    assert cold["total"] > 0 and warm["total"] > 0 and "trace" in cold
    # numba compiles in the cold process only: it takes longer than the warm one
    assert cold_s > warm_s and cold["total"] > warm["total"]
    for row in ("cold (whole process)", "warm (whole process)", "cold / warm", "cold total"):
        assert row in text


@pytest.mark.gl
def test_tradeoff_study_writes_a_tiny_study_of_one_scene(tmp_path):
    out = tmp_path / "studies"
    text = run_tool("tradeoff_study.py", [
        "--scenes", "ring", "--quick", "--out", out, "--photons", "1000,2000", "--A", "8",
        "--k", "8", "--size", "16x16", "--reference-photons", "20000",
        "--cache", tmp_path / "cache"], tmp_path)
    assert "-m blockhash tradeoff" in text and str(out / "ring") in text
    assert sorted(p.name for p in out.iterdir()) == ["ring"]
    study = json.loads((out / "ring" / "tradeoff.json").read_text())
    assert (ROOT / "scenes" / "ring.toml").samefile(study["scene"]) and study["size"] == [16, 16]
    assert study["plan"]["photons"] == [1000, 2000] and study["plan"]["ks"] == [8]
    rows = study["rows"]
    assert {r["method"] for r in rows} >= {"exact-ckdtree", "bh", "cover"}
    for r in rows:
        assert math.isfinite(r["rel_rms_exact"]) and math.isfinite(r["rel_rms_reference"])
    exact = [r for r in rows if r["method"] == "exact-ckdtree"]
    assert all(r["rel_rms_exact"] == 0 and r["flux_ratio_exact"] == 1 for r in exact)
    # the default Block Hashing lookup finds nearly the exact neighbours at k = 8 (it is
    # approximate: on 1,000 photons it may miss a neighbour in a few pixels, 0.006 measured)
    bh = [r for r in rows if r["method"] == "bh" and r["k"] == 8]
    assert bh and all(r["rel_rms_exact"] < 0.02 for r in bh)
    for name in ("report.md", "images.exr", "pareto.png"):
        assert (out / "ring" / name).stat().st_size > 0
    assert list(tmp_path.glob("cache/lighttrace-*.npz"))


@pytest.mark.gl
def test_shader_stats_compiles_the_cells_lookup_on_rdna2(tmp_path):
    """The cells lookup and its fetch-only floor on RADV's null RDNA2 device (skipped where
    the toolchain is missing, unless BLOCKHASH_REQUIRE_GPU_COMPILER is set)."""
    out = tmp_path / "stats.json"
    args = ["--family", "navi21", "--scene", "", "--lookups", "cells", "--no-kdtree",
            "--backend", "egl", "--json", out]
    run = subprocess.run([sys.executable, str(TOOLS_DIR / "shader_stats.py"), *map(str, args)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=600)
    if run.returncode == 2 and run.stderr.startswith("shader_stats: "):
        if os.environ.get("BLOCKHASH_REQUIRE_GPU_COMPILER"):
            pytest.fail(f"BLOCKHASH_REQUIRE_GPU_COMPILER is set but {run.stderr}")
        pytest.skip(run.stderr.strip())
    assert run.returncode == 0, run.stderr[-3000:]
    written = json.loads(out.read_text())
    assert written["command"].endswith("--scene '' --lookups cells --no-kdtree --backend egl "
                                       f"--json {out}")
    rows = written["rows"]
    assert [(r["shader"], r["family"]) for r in rows] == [
        ("lookup cells", "navi21"), ("lookup cells fetch-only", "navi21")]
    for r in rows:  # the cells lookup fits the budget: no scratch, no spills, <= 64 VGPRs
        assert r["wave"] == 64 and 0 < r["preVGPRs"] <= 64 and r["instructions"] > 0
        assert r["scratch_lane"] == 0 and r["spilledVGPRs"] == 0
    assert rows[1]["instructions"] < rows[0]["instructions"]  # the floor only fetches
    assert [line.split()[:3] for line in run.stdout.splitlines()[1:]] == [
        ["lookup", "cells", "navi21"], ["lookup", "cells", "fetch-only"]]
    table = run_tool("shader_stats.py", ["--table", out], tmp_path).splitlines()
    assert len(table) == 4 and table[2].startswith(f"| lookup cells | {rows[0]['VGPRs']} (")


def test_gpu_bench_parses():
    run = subprocess.run(["bash", "-n", str(TOOLS_DIR / "gpu_bench.sh")], capture_output=True,
                         text=True)
    assert run.returncode == 0, run.stderr


@pytest.mark.gl
def test_gpu_bench_rehearses_its_k_sweep_on_the_local_gl(tmp_path):
    """A tiny rehearsal on the local GL (llvmpipe): the device, k sweep and GL test steps."""
    run, out = _gpu_bench(tmp_path, SMALL="1", STEPS="device,k,tests", PHOTONS="2000",
                          QUERIES="256", REPEAT="1", WARMUP="0", KS="8")
    assert sorted(p.name for p in out.iterdir()) == ["bench_k.txt", "bench_k8.json", "device.txt",
                                                     "tests.txt"]
    assert "renderer" in (out / "device.txt").read_text()
    rows = json.loads((out / "bench_k8.json").read_text())
    methods = [r["method"] for r in rows]
    assert {"BH default", "BH binary-set-on-merge-box", "BH fetch-only floor"} <= set(methods)
    assert all(r["draws"] == 1 and r["seconds"] > 0 for r in rows)
    assert [r["fn_percent"] for r in rows if r["method"] == "BH default"] == [0.0]
    assert "BH default" in (out / "bench_k.txt").read_text()
    assert " passed" in (out / "tests.txt").read_text()
    assert "failed" not in (out / "tests.txt").read_text()
    assert "== done: " in run.stderr


def test_gpu_bench_fails_when_a_step_fails(tmp_path):
    """Every step runs even after one failed, and the exit status says one did."""
    run = _gpu_bench(tmp_path, STEPS="k", KS="0", expect=1)[0]
    assert "done, with failed steps" in run.stderr


def test_gpu_bench_rehearses_its_photon_step_on_the_cpu_kernels(tmp_path):
    """The photons step on this machine's Dr.Jit CPU device, tiny: tracing alone beside
    Mitsuba's ptracer (tools/trace_speed.py) and whole passes in one process and on a worker
    (tools/device_pass.py)."""
    from blockhash.device.choice import resolve
    from blockhash.errors import InputError

    mitsuba_or_skip()
    try:
        resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")
    run, out = _gpu_bench(tmp_path, SMALL="1", STEPS="photons", CAUSTIC="5000", REPEAT="1",
                          SIZE="32", WORKERS="1")
    speed = json.loads((out / "trace_speed.json").read_text())["rows"]
    assert [r["scene"] for r in speed] == ["ring", "sun", "cbox"]
    assert all(r["kernels"]["device"] == "cpu" and r["kernels"]["stored"] == 5000 for r in speed)
    passes = json.loads((out / "device_pass.json").read_text())["rows"]
    assert [(r["scene"], r["workers"]) for r in passes] == [
        ("ring", 0), ("ring", 1), ("venus", 0), ("venus", 1), ("cbox", 0), ("cbox", 1)]
    for r in passes:
        assert r["device"] == "cpu" and r["stored"] > 0 and r["stored_per_photon_s"] > 0
    # the same passes' photons in one process as on a worker
    by = {(r["scene"], r["workers"]): r["stored"] for r in passes}
    assert all(by[(s, 0)] == by[(s, 1)] for s in ("ring", "venus", "cbox"))
    assert "== done: " in run.stderr


@pytest.mark.gl
def test_gpu_bench_rehearses_its_frames_step_here(tmp_path):
    """The frames step, tiny: the ring's orbit and light circling through the frame session at
    two sizes (one sample a pixel here; 1 and 9 on the GPU), venus and the box at one
    (tools/frames_bench.py's latency step)."""
    run, out = _gpu_bench(tmp_path, SMALL="1", STEPS="frames", SIZE="24", FRAMES_BIG="32",
                          FRAME_PHOTONS="2000", FRAMES="2", FRAME_SPP="1")
    ring = json.loads((out / "frames_ring.json").read_text())
    assert {(r["size"], r["spp"], r["motion"]) for r in ring["latency"]} == {
        (s, 1, m) for s in (24, 32) for m in ("camera orbit", "light circling")}
    assert ring["flicker"] == [] and ring["memory"] == []
    others = json.loads((out / "frames_others.json").read_text())
    assert {r["scene"] for r in others["latency"]} == {"venus", "cbox"}
    assert all(r["fps"] > 0 and r["commit"] == "this" for r in ring["latency"] + others["latency"])
    assert "== done: " in run.stderr


def _gpu_bench(tmp_path, expect: int = 0, **env):
    """(the finished run, its OUT folder) of tools/gpu_bench.sh with ``env`` (OUT under
    ``tmp_path``), this interpreter first on PATH; its exit status must be ``expect``."""
    env = dict(os.environ, OUT=str(tmp_path / "out"), **env)
    env["PATH"] = f"{os.path.dirname(sys.executable)}{os.pathsep}{env['PATH']}"
    run = subprocess.run(["bash", str(TOOLS_DIR / "gpu_bench.sh")], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == expect, run.stderr[-3000:]
    return run, tmp_path / "out"


def test_gpu_carry_packs_the_wheels_stored_and_unpacks_them_to_whl(tmp_path):
    """The carry's archive holds every file of .whl/, each wheel the same members stored
    uncompressed (still a zip pip installs), and unpacks to .whl/; the sizes are printed
    against the 64 MiB limit."""
    import tarfile
    import zipfile

    root = tmp_path / "checkout"
    (root / ".whl").mkdir(parents=True)
    subprocess.run(["git", "init", "-q", str(root)], check=True)
    (root / "tracked.txt").write_text("x" * 1000)
    subprocess.run(["git", "-C", str(root), "add", "tracked.txt"], check=True)
    members = {"pkg/__init__.py": b"print('hi')\n" * 200, "pkg-1.0.dist-info/RECORD": b""}
    with zipfile.ZipFile(root / ".whl" / "pkg-1.0-py3-none-any.whl", "w",
                         zipfile.ZIP_DEFLATED) as z:
        for name, data in members.items():
            z.writestr(name, data)
    (root / ".whl" / "run.sh").write_text("#!/usr/bin/env bash\n")
    text = run_tool("gpu_carry.py", ["--root", root], tmp_path)
    assert "carried in all" in text and "of 64" in text
    out = tmp_path / "unpacked"
    with tarfile.open(root / ".carry" / "whl.tar.xz") as tar:
        assert sorted(tar.getnames()) == [".whl/pkg-1.0-py3-none-any.whl", ".whl/run.sh"]
        tar.extractall(out, filter="data")
    with zipfile.ZipFile(out / ".whl" / "pkg-1.0-py3-none-any.whl") as z:
        assert {i.filename: z.read(i) for i in z.infolist()} == members
        assert all(i.compress_type == zipfile.ZIP_STORED for i in z.infolist())
