"""The tools that measure the caustic's density estimate (against exact kNN, the light-traced
reference, a finer tessellation, a synthetic fold), each run on a tiny input from a folder
outside the checkout: the rows they print or write hold the figures they promise."""

import json
import math

import numpy as np
import pytest
from conftest import TOOLS_DIR, run_tool


def _table(text: str, first: str) -> list[list[str]]:
    """The cells of the markdown rows of ``text`` that begin with ``| first |``."""
    return [[c.strip() for c in line.strip().strip("|").split("|")]
            for line in text.splitlines() if line.startswith(f"| {first} |")]


def test_fold_bias_adds_flux_at_a_fold_and_none_without_an_edge(tmp_path):
    text = run_tool("fold_bias.py", ["--shapes", "fold,smooth", "--photons", "2e4",
                                     "--ks", "25", "--points", "200"], tmp_path)
    assert text.splitlines()[0] == "| shape | N | k | none | cone | epanechnikov | silverman |"
    [fold], [smooth] = _table(text, "fold"), _table(text, "smooth")
    assert fold[:3] == ["fold", "20,000", "25"] and smooth[:3] == ["smooth", "20,000", "25"]
    fold, smooth = [float(v) for v in fold[3:]], [float(v) for v in smooth[3:]]
    assert fold[0] > max(fold[1:]) > 1.005  # the box adds most at the fold, every filter some
    assert all(abs(v - 1) < 0.02 for v in smooth)  # no edge: the power conserved
    # the conserving estimate keeps the fold's power
    text = run_tool("fold_bias.py", ["--shapes", "fold", "--photons", "2e4", "--ks", "25",
                                     "--points", "200", "--estimate", "conserving"], tmp_path)
    [fold] = _table(text, "fold")
    assert all(abs(float(v) - 1) < 0.01 for v in fold[3:])


def _cache(tmp_path):
    """A reference cache of the test's own, so that every run traces its tiny reference."""
    return ["--cache", tmp_path / "cache"]


@pytest.mark.gl
def test_spp_sweep_writes_a_row_per_spp_near_the_reference(tmp_path):
    out = tmp_path / "sweep.json"
    text = run_tool("spp_sweep.py", ["ring", "--size", "24x24", "--spp", "1,4", "--photons", "5e3",
                                     "--reference", "2e5", *_cache(tmp_path), "--json", out],
                    tmp_path)
    saved = json.loads(out.read_text())
    assert saved["command"].startswith("python tools/spp_sweep.py ring --size 24x24")
    rows = saved["rows"]
    assert [(r["scene"], r["spp"], r["photons"]) for r in rows] == [("ring", 1, 5000),
                                                                    ("ring", 4, 5000)]
    for r in rows:
        assert 0.8 < r["flux"] < 1.2 and 0 < r["blur"] < 0.5 and math.isfinite(r["blur_all"])
        assert r["reference_photons"] == 200_000 and 0 < r["pixels_region"] <= r["pixels_compared"]
        assert r["seconds"] > 0 and "caustic" in r["timings"]
    assert text.count("  spp ") == 2 and "ring: reference 200,000 photons" in text
    assert list((tmp_path / "cache").glob("lighttrace-*.npz"))


@pytest.mark.gl
def test_photon_radii_finds_the_index_radii_exact_on_a_tiny_map(tmp_path):
    text = run_tool("photon_radii.py", ["scenes/ring.toml", "--size", "24", "--photons", "5e3",
                                        "--reference", "2e5", *_cache(tmp_path)], tmp_path)
    lines = text.splitlines()
    assert lines[0].startswith("ring: 5,000 photons; index ")
    # the index's own radii are the exact ones here: ratio 1, the same images
    assert "mean 1.0000, median 1.0000" in lines[0] and "same 100.0%" in lines[0]
    fluxes = [float(line.split("flux ")[1].split()[0]) for line in lines if " radii: flux " in line]
    assert len(fluxes) == 2 and fluxes[0] == fluxes[1] and 0.8 < fluxes[0] < 1.2
    assert lines[-1] == "  own against exact: relative RMS 0.0000"
    text = run_tool("photon_radii.py", ["ring", "--photons", "5e3", "--times-only",
                                        "--repeat", "2"], tmp_path)
    [line] = text.splitlines()
    assert line.startswith("ring, 5,000 photons, median of 2: index (render: no tables) ")
    seconds = [float(part.split()[-2]) for part in line.split(": ", 1)[1].split("; ")]
    assert len(seconds) == 4 and all(0 <= s < 60 for s in seconds)


@pytest.mark.gl
def test_render_accuracy_converges_to_the_exact_image_as_a_grows(tmp_path):
    text = run_tool("render_accuracy.py", ["scenes/ring.toml", "--size", "32x32", "--photons",
                                           "2e4", "--A", "1,16"], tmp_path)
    lines = text.splitlines()
    assert lines[0] == ("scenes/ring.toml: 20,000 photons, 32x32, k=50; exact = cKDTree k "
                        "nearest on the same map")
    rows = {int(a): (float(err), float(ratio)) for a, err, ratio, _ in map(str.split, lines[2:])}
    assert sorted(rows) == [1, 16]
    assert rows[1][1] < 0.95 and rows[1][0] > 0.05  # A = 1: the Block Hashing image darker
    assert rows[16][0] < 0.01 and abs(rows[16][1] - 1) < 0.01  # A = 16: the exact image


@pytest.mark.gl
def test_caustic_flux_check_prints_each_method_and_count_against_the_reference(tmp_path):
    text = run_tool("caustic_flux_check.py", ["scenes/ring.toml", "--photons", "2e4,5000",
                                              "--size", "24x24", "--reference-photons", "2e5",
                                              *_cache(tmp_path)], tmp_path)
    lines = text.splitlines()
    assert lines[0].startswith("scenes/ring.toml (ks = 0), 24x24 (x2 supersampled), reference "
                               "200,000 photons (")
    assert str(tmp_path / "cache") in lines[0]
    rows = [line.rsplit(None, 4) for line in lines[2:]]
    assert [(r[0], r[1]) for r in rows] == [("exact kNN (cKDTree)", "20,000"),
                                            ("BH default A=8", "20,000"),
                                            ("exact kNN (cKDTree)", "5,000"),
                                            ("BH default A=8", "5,000")]
    for _, _, flux, rms, blur in rows:
        assert 0.85 < float(flux) < 1.15 and 0 < float(blur) < float(rms) < 0.5


def test_sphere_tessellation_compares_each_subdivision_with_the_finest(tmp_path):
    text = run_tool("sphere_tessellation.py", ["--photons", "2e4", "--subdivisions", "2,3",
                                               "--finest", "4", "--cell", "0.01"], tmp_path)
    lines = text.splitlines()
    assert lines[0].startswith("glass.toml: 20,000 photons stored, histogram ")
    assert lines[0].endswith("cells of 10 mm over the caustic; against subdivisions 4")
    rows = [line.split() for line in lines[2:]]
    assert [(r[0], r[1]) for r in rows] == [("2", "320"), ("3", "1,280"), ("4", "5,120")]
    err, flux = [float(r[2]) for r in rows], [float(r[3]) for r in rows]
    assert err[2] == 0 and flux[2] == 1  # the finest against itself
    assert err[0] > err[1] > 0 and all(abs(f - 1) < 0.05 for f in flux)


def _trade_study(folder, cache, darkening: dict) -> None:
    """A trade study's ``tradeoff.json`` and ``images.exr`` (24 x 24, the ring scene), its
    image at each A the reference times ``darkening[A]``."""
    from blockhash.evaluate.images import write_exr
    from blockhash.reference.lighttrace import cached_reference, lambertian
    from blockhash.scene.loader import load_scene

    scene = lambertian(load_scene(TOOLS_DIR.parent / "scenes" / "ring.toml"))
    ref, _ = cached_reference(scene, 200_000, size=(24, 24), cache_dir=cache)
    folder.mkdir()
    (folder / "tradeoff.json").write_text(json.dumps({
        "scene": "scenes/ring.toml", "lambertian": True, "reference": {"photons": 200_000},
        "size": [24, 24], "plan": {"photons": [5000], "k0": 50}}))
    reference = ref.radiance.astype(np.float32)
    write_exr(folder / "images.exr", {"reference": reference,
                                      **{f"A{a}": reference * g for a, g in darkening.items()}})


def test_darkening_check_fits_a_gain_per_a_and_tests_it_on_the_other_study(tmp_path):
    cache = tmp_path / "cache"
    _trade_study(tmp_path / "fit", cache, {1: 0.8, 4: 0.95})
    _trade_study(tmp_path / "test", cache, {1: 0.9, 4: 0.95, 16: 1.0})
    text = run_tool("darkening_check.py", [tmp_path / "fit", tmp_path / "test", "--cache", cache],
                    tmp_path)
    lines = text.splitlines()
    assert lines[0] == "gains fitted on scenes/ring.toml, tested on scenes/ring.toml (N = 5,000, k = 50)"
    rows = {int(r[0]): [float(v) for v in r[1:]] for r in map(str.split, lines[2:])}
    assert sorted(rows) == [1, 4]  # the A both studies hold
    gain, before, after, rms_before, rms_after = rows[1]
    assert (gain, before, after) == (1.25, 0.9, 1.125)
    assert rows[4][:3] == [1.053, 0.95, 1.0] and rows[4][4] < 0.001 < rows[4][3]


@pytest.mark.gl
def test_estimate_study_writes_every_option_and_prints_its_tables_again(tmp_path, monkeypatch):
    # the bounds below were read on the host tracer's photons (2,000 of them: noisy)
    monkeypatch.setenv("BLOCKHASH_DEVICE", "host")
    out, md = tmp_path / "study.json", tmp_path / "tables.md"
    text = run_tool("estimate_study.py", ["--scenes", "corner", "--photons", "2000", "--ks", "10",
                                          "--size", "16", "--supersample", "1",
                                          "--reference-photons", "1e5", *_cache(tmp_path),
                                          "--json", out, "--markdown", md], tmp_path)
    [study] = json.loads(out.read_text())
    rows = study["rows"]
    assert {(r["photons"], r["k"]) for r in rows} == {(2000, 10)}
    every = _table(text.split("Every option:")[1], "corner")
    assert len(every) == 16 and sum(r[3] == "exact" for r in every) == 2
    for r in every:  # 2,000 photons at 16 x 16: flux 0.90-1.70 over two photon sets (measured)
        assert 0.4 < float(r[5]) < 2.0 and 0 < float(r[6]) < 1
    # the exact search's paper row: the same estimate on the exact neighbours, near BH's
    assert every[0][4] == every[14][4] and abs(float(every[0][5]) - float(every[14][5])) < 0.05
    assert md.read_text() == text[text.index("Each option, flux"):]
    again = run_tool("estimate_study.py", ["--from-json", out], tmp_path)
    assert again == text[text.index("Each option, flux"):]
