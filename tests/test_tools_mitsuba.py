"""tools/mitsuba_tables.py and tools/mitsuba_folder.py on tiny inputs (skipped without
Mitsuba, unless BLOCKHASH_REQUIRE_MITSUBA is set, as CI sets it)."""

import json
from pathlib import Path

import pytest
from conftest import mitsuba_or_skip, run_tool

PUBLISHED = Path(__file__).resolve().parent / "data" / "mitsuba_published" / "docs" / "scenes"


def test_the_tables_the_import_reads_are_mitsubas(tmp_path):
    """``"mitsuba_tables.py" --check``: the committed CIE and conductor tables are what
    Mitsuba gives now (the tool writes nothing with --check)."""
    mitsuba_or_skip()
    text = run_tool("mitsuba_tables.py", ["--check"], tmp_path)
    assert "largest difference from Mitsuba's functions" in text
    assert "conductor presets: largest difference" in text


@pytest.mark.gl
def test_the_folder_tool_tabulates_renders_and_refusals(tmp_path):
    """``"mitsuba_folder.py"`` on a rendered box and a refused file: one row each, the
    refusal's reason counted, the rows in its JSON."""
    mitsuba_or_skip()
    out = tmp_path / "rows.json"
    text = run_tool("mitsuba_folder.py", [PUBLISHED / "integrator_depth_2.xml",
                                          PUBLISHED / "bsdf_pplastic.xml",
                                          "--size", "16", "--spp", "16", "--passes", "1",
                                          "--peer-spp", "2", "--json", out], tmp_path)
    assert "| integrator_depth_2.xml | yes | 1 |" in text
    assert "| Mitsuba at 2 spp, blurred |" in text
    assert "| bsdf_pplastic.xml | no: <bsdf type=\"pplastic\">" in text
    assert "1 of 2 render." in text
    rendered, refused = json.loads(out.read_text())
    assert rendered["refused"] is None and len(rendered["flux"]) == 3
    assert abs(rendered["flux"][1] - 1) < 0.2  # 16 pixels, 16 samples: loose, but the same light
    assert 0.0 < rendered["peer_blurred_rel_rms"] < 2.0  # Mitsuba's own 2 samples: noisy
    assert "bsdf_pplastic.xml:4" in refused["refused"]
