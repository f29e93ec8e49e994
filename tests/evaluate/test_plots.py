"""Heat maps and strips: the colours land where the error is, one panel per layer."""

import numpy as np
import OpenImageIO as oiio
import pytest
from matplotlib import colormaps

from blockhash.errors import InputError
from blockhash.evaluate.plots import CMAP, save_heatmap, save_strip


def pixels(path):
    return oiio.ImageBuf(str(path)).get_pixels(oiio.UINT8)[..., :3].astype(int)


def has_colour(img, rgb, tol=6):
    return bool(np.any(np.all(np.abs(img - np.asarray(rgb)) <= tol, axis=2)))


def rgb8(value):
    return np.round(np.asarray(colormaps[CMAP](value)[:3]) * 255).astype(int)


def test_heatmap_shows_the_hot_spot_in_the_top_colour_and_masked_pixels_grey(tmp_path):
    e = np.zeros((32, 32))
    e[8:16, 8:16] = 1.0
    e[24:, 24:] = np.nan
    path = save_heatmap(tmp_path / "h.png", {"caustic": e}, label="FLIP", vmax=1.0)
    img = pixels(path)
    assert has_colour(img, rgb8(1.0)) and has_colour(img, rgb8(0.0))
    assert has_colour(img, (153, 153, 153), tol=1)   # grey "0.6" for NaN
    # Without the hot spot the top colour appears only in the colour bar: far fewer pixels.
    cool = pixels(save_heatmap(tmp_path / "c.png", {"caustic": e * 0.0}, label="FLIP", vmax=1.0))
    top = lambda im: np.all(np.abs(im - rgb8(1.0)) <= 6, axis=2).sum()  # noqa: E731
    assert top(img) > 2 * top(cool)


@pytest.mark.slow
def test_one_panel_per_layer_and_a_row_per_layer_in_the_strip(tmp_path):
    maps = {name: np.random.default_rng(0).random((16, 16)) for name in ("direct", "caustic")}
    one = oiio.ImageInput.open(str(save_heatmap(tmp_path / "1.png", {"direct": maps["direct"]},
                                                label="e"))).spec()
    two = oiio.ImageInput.open(str(save_heatmap(tmp_path / "2.png", maps, label="e"))).spec()
    assert two.width > 1.7 * one.width and two.height == one.height
    ldr = {name: np.full((16, 16, 3), 0.5) for name in maps}
    strip = oiio.ImageInput.open(str(save_strip(tmp_path / "s.png", ldr, ldr, maps,
                                                label="e"))).spec()
    assert strip.height > 1.7 * one.height and strip.width > 2.5 * one.width


def test_bad_maps_and_paths_are_refused(tmp_path):
    with pytest.raises(InputError, match=r"layer 'direct' has shape \(4, 4, 3\); expected \(h, w\)"):
        save_heatmap(tmp_path / "h.png", {"direct": np.zeros((4, 4, 3))}, label="e")
    with pytest.raises(InputError, match="no error map to draw"):
        save_heatmap(tmp_path / "h.png", {}, label="e")
    with pytest.raises(InputError, match=r"directory .*nowhere does not exist"):
        save_heatmap(tmp_path / "nowhere" / "h.png", {"d": np.zeros((4, 4))}, label="e")
    with pytest.raises(InputError, match=r"layer\(s\) \['d'\] have an error map but no A or B"):
        save_strip(tmp_path / "s.png", {}, {}, {"d": np.zeros((4, 4))}, label="e")
    img = {"d": np.zeros((5, 4, 3))}
    with pytest.raises(InputError, match=r"layer 'd' of A is 4x5 but its error map is 4x4"):
        save_strip(tmp_path / "s.png", img, img, {"d": np.zeros((4, 4))}, label="e")


def test_default_scale_is_the_99th_percentile_so_one_outlier_does_not_blacken_the_map(tmp_path):
    e = np.tile(np.linspace(0.0, 1.0, 64), (64, 1))
    e[0, 0] = 1000.0
    img = pixels(save_heatmap(tmp_path / "h.png", {"d": e}, label="e"))
    assert has_colour(img, rgb8(0.5))               # the ramp's middle keeps its colour
    flat = pixels(save_heatmap(tmp_path / "f.png", {"d": e}, label="e", vmax=1000.0))
    assert not has_colour(flat[:, : flat.shape[1] * 3 // 4], rgb8(0.5))
