"""The tools that measure the caustic's density estimate (against exact kNN, the light-traced
reference, a finer tessellation, a synthetic fold), each run on a tiny input from a folder
outside the checkout: the rows they print or write hold the figures they promise."""


from conftest import run_tool


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
