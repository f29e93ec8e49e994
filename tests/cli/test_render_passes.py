"""blockhash render in passes: its stopping flags, the PNG previews, and Ctrl-C writing the
image so far."""

import pytest

RING = __import__("pathlib").Path(__file__).resolve().parents[2] / "scenes" / "ring.toml"


@pytest.mark.gl
def test_ctrl_c_writes_the_image_so_far_with_its_pass_count(tmp_path, monkeypatch, capsys):
    import blockhash.passes.executors as executors
    from blockhash.cli import main
    from blockhash.evaluate.images import read_attribute, read_layers

    real = executors.run_pass

    def run_pass(setup, p, emitted, **kw):
        if p == 2:
            raise KeyboardInterrupt
        return real(setup, p, emitted, **kw)
    monkeypatch.setattr(executors, "run_pass", run_pass)
    out = tmp_path / "ring.exr"
    code = main(["render", str(RING), "--size", "24x24", "--photons", "3000", "--passes", "9",
                 "-o", str(out)])
    assert code == 130
    assert "interrupted (Ctrl-C); wrote the image of 2 passes" in capsys.readouterr().err
    assert int(read_attribute(out, "blockhash:passes")) == 2
    assert read_layers(out)["caustic"].max() > 0 and out.with_suffix(".png").is_file()


@pytest.mark.gl
def test_the_render_command_runs_passes_to_its_rule(tmp_path, capsys, monkeypatch):
    from blockhash.cli import main
    from blockhash.evaluate import images
    from blockhash.evaluate.images import read_attribute

    written = []
    real_png = images.write_png
    monkeypatch.setattr(images, "write_png", lambda path, img: (written.append(path),
                                                                real_png(path, img)))
    out = tmp_path / "ring.exr"
    assert main(["render", str(RING), "--size", "24x24", "--photons", "3000", "--passes", "3",
                 "--preview-every", "0.001", "-o", str(out)]) == 0
    # a preview after each pass (each ends more than 1 ms after the last), then the final PNG
    assert written == [out.with_suffix(".png")] * 4
    text = capsys.readouterr().out
    assert "passes: 3 (3 passes)" in text and "relative standard error" in text
    assert int(read_attribute(out, "blockhash:passes")) == 3
    assert int(read_attribute(out, "blockhash:spp")) == 3
    for flags, match in ((["--passes", "0"], "--passes 0: a render runs at least one pass"),
                         (["--time", "0"], "--time 0.0: the time limit must be a positive"),
                         (["--alpha", "1"], r"--alpha 1.0 is outside \(0, 1\)"),
                         (["--target-error", "-1"], "--target-error -1.0: .* must be > 0"),
                         (["--passes", "3", "--target-error", "1e-9"],
                          "--target-error 1e-09 cannot be reached within --passes 3"),
                         (["--preview-every", "0"], "--preview-every 0.0: the PNG is rewritten")):
        code = main(["render", str(RING), "--size", "16x16", "--photons", "3000", *flags,
                     "-o", str(out)])
        assert code == 2
        assert __import__("re").search(match, capsys.readouterr().err), flags

