"""Image assertions for tests: ``assert_images_close`` with the limits of ``blockhash compare``.

A reference-image test in five lines::

    from blockhash.passes.pipeline import render_scene
    from blockhash.scene.loader import load_scene
    from blockhash.evaluate.testing import assert_images_close

    def test_ring_matches_its_reference(tmp_path):
        result = render_scene(load_scene("scenes/ring.toml"), photons=20_000, size=(48, 48), seed=1)
        assert_images_close(result.layers(), "tests/data/ring.exr", max_rel_rms=0.1,
                            out_dir=tmp_path)

On failure the AssertionError lists every layer and metric over its limit and
names a FLIP heat map and an A | B | error strip written to ``out_dir``
(pytest's ``tmp_path``, so they sit next to the failing test's output).
"""

from __future__ import annotations

import re
import tempfile
from pathlib import Path

from blockhash.evaluate.imagediff import Comparison, compare_layers, write_pictures


def assert_images_close(actual, reference, *, max_rms=None, max_rel_rms=None, max_flip=None,
                        mask=None, out_dir=None, name: str | None = None,
                        error: str = "flip") -> Comparison:
    """Fail unless ``actual`` is within the limits of ``reference`` in every layer.

    Parameters
    ----------
    actual, reference : path, ``{layer: (h, w, 3) array}`` (``RenderResult.layers()``), or one
        (h, w, 3) / (h, w) array
    max_rms, max_rel_rms, max_flip : float or ``{layer: float}`` (``'*'``: the other layers)
        At least one must be given: a comparison without a limit cannot fail.
    mask : layer name of ``actual``, mask image path or (h, w) array, optional
        Compare only where it is non-zero.
    out_dir : path, optional
        Where the heat map and strip go on failure (default: a new temporary directory).
    name : str, optional
        File name stem of the pictures (default: the current pytest test's name, or "images").
    error : {'flip', 'abs'}
        What the pictures show.

    Returns the :class:`~blockhash.evaluate.imagediff.Comparison` when the images are close.
    Bad input (missing file, different sizes or layers, unknown layer in a limit) raises
    :class:`~blockhash.errors.InputError`, not AssertionError.
    """
    from blockhash.errors import InputError

    if max_rms is None and max_rel_rms is None and max_flip is None:
        raise InputError("assert_images_close needs max_rms, max_rel_rms or max_flip; without a "
                         "limit the comparison cannot fail")
    result = compare_layers(actual, reference, max_rms=max_rms, max_rel_rms=max_rel_rms,
                            max_flip=max_flip, mask=mask, names=("actual", "reference"))
    if result.passed:
        return result
    stem = name or _test_name()
    out = Path(out_dir) if out_dir is not None else Path(tempfile.mkdtemp(prefix="blockhash-"))
    out.mkdir(parents=True, exist_ok=True)
    heatmap, strip = write_pictures(result, heatmap=out / f"{stem}.heatmap.png",
                                    strip=out / f"{stem}.strip.png", error=error)
    lines = [f"images differ beyond the limits ({len(result.failures)} failure(s)):"]
    lines += [f"  {failure}" for failure in result.failures]
    lines += [result.table(), f"heat map: {heatmap}", f"strip (actual | reference | error): {strip}"]
    raise AssertionError("\n".join(lines))


def _test_name() -> str:
    """The running pytest test's name as a file stem ('images' outside pytest)."""
    import os

    current = os.environ.get("PYTEST_CURRENT_TEST", "")
    test = current.split(" ")[0].split("::")[-1] if current else "images"
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", test) or "images"
