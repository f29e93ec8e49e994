"""Per-layer comparison: metrics against OpenImageIO and by hand, limits, masks, FLIP, errors."""

import numpy as np
import OpenImageIO as oiio
import pytest

from blockhash.errors import InputError
from blockhash.evaluate.imagediff import compare_images, compare_layers, flip_map
from blockhash.evaluate.images import read_layers, write_exr, write_rgb8


def layers(h=24, w=32, seed=0):
    rng = np.random.default_rng(seed)
    direct = rng.random((h, w, 3)).astype(np.float32)
    caustic = (rng.random((h, w, 3)) * 0.2).astype(np.float32)
    return {"direct": direct, "caustic": caustic}


def test_identical_images_have_zero_error_and_pass_zero_limits():
    a = layers()
    r = compare_layers(a, a, max_rms=0.0, max_rel_rms=0.0, max_flip=0.0)
    assert r.passed and r.failures == []
    assert all(v == 0 for m in r.metrics.values() for v in m.values())


def test_metrics_match_openimageio_and_the_definitions():
    a, b = layers(seed=1), layers(seed=2)
    r = compare_layers(a, b)
    for name in a:
        ref = oiio.ImageBufAlgo.compare(oiio.ImageBuf(a[name]), oiio.ImageBuf(b[name]), 0.0, 0.0)
        m = r.metrics[name]
        assert m["rms"] == pytest.approx(ref.rms_error, rel=1e-6)
        assert m["max"] == pytest.approx(ref.maxerror, rel=1e-6)
        assert m["mean"] == pytest.approx(ref.meanerror, rel=1e-6)
        assert m["relative_rms"] == pytest.approx(m["rms"] / np.sqrt(np.mean(b[name] ** 2.0)))
        assert 0 < m["flip"] <= 1


def test_one_limit_covers_every_layer_and_a_named_layer_overrides_it():
    b = layers()
    a = {"direct": b["direct"] + 0.1, "caustic": b["caustic"] + 0.01}
    r = compare_layers(a, b, max_rms=0.05)
    assert [(f.layer, f.metric) for f in r.failures] == [("direct", "rms")]
    assert r.failures[0].value == pytest.approx(0.1, rel=1e-5) and r.failures[0].limit == 0.05
    assert compare_layers(a, b, max_rms={"*": 0.05, "direct": 0.2}).passed
    only = compare_layers(a, b, max_rms={"caustic": 0.001})
    assert [(f.layer, f.metric) for f in only.failures] == [("caustic", "rms")]
    assert "direct" not in only.limits["rms"]
    assert "1.99x the limit" in str(compare_layers(a, b, max_rms={"direct": 0.0502}).failures[0])


def test_nan_in_the_image_fails_every_limit():
    b = layers()
    a = {k: v.copy() for k, v in b.items()}
    a["caustic"][3, 4, 0] = np.nan
    r = compare_layers(a, b, max_rel_rms=10.0)
    assert [f.layer for f in r.failures] == ["caustic"]


def test_black_reference_gives_infinite_relative_rms_unless_both_are_black():
    zero = {"rgb": np.zeros((8, 8, 3), np.float32)}
    assert compare_layers(zero, zero, max_rel_rms=0.0).passed
    r = compare_layers({"rgb": np.full((8, 8, 3), 0.1, np.float32)}, zero, max_rel_rms=1e9)
    assert r.metrics["rgb"]["relative_rms"] == np.inf and not r.passed


def test_mask_layer_limits_the_comparison_to_its_non_zero_pixels():
    b = layers()
    b["caustic"][:, :16] = 0
    a = {k: v.copy() for k, v in b.items()}
    a["direct"][:, :16] += 1.0        # only where the caustic is black
    assert not compare_layers(a, b, max_rms=1e-6).passed
    r = compare_layers(a, b, max_rms=1e-6, mask="caustic")
    assert r.passed and r.mask.sum() == 24 * 16
    assert "mask: 384 of 768 pixels" in r.table()


def test_mask_image_file_and_its_errors(tmp_path):
    b = layers()
    a = {k: v.copy() for k, v in b.items()}
    a["direct"][:12] += 1.0
    m = np.zeros((24, 32, 3), np.uint8)
    m[12:] = 255
    write_rgb8(tmp_path / "mask.png", m)
    assert compare_layers(a, b, max_rms=1e-6, mask=str(tmp_path / "mask.png")).passed
    write_rgb8(tmp_path / "small.png", m[:10])
    with pytest.raises(InputError, match=r"small\.png.*32x10 but the images are 32x24"):
        compare_layers(a, b, mask=str(tmp_path / "small.png"))
    write_rgb8(tmp_path / "black.png", m * 0)
    with pytest.raises(InputError, match="selects no pixel"):
        compare_layers(a, b, mask=str(tmp_path / "black.png"))
    with pytest.raises(InputError, match=r"'shadow' is neither a layer of the first image "
                                         r"\(caustic, direct\) nor an image file"):
        compare_layers(a, b, mask="shadow")


def test_different_layers_and_sizes_are_named(tmp_path):
    a, b = layers(), layers()
    write_exr(tmp_path / "a.exr", a)
    write_exr(tmp_path / "b.exr", {"direct": b["direct"]})
    with pytest.raises(InputError, match=r"a\.exr and .*b\.exr have different layers.*only in "
                                         r".*a\.exr: \['caustic'\]"):
        compare_layers(tmp_path / "a.exr", tmp_path / "b.exr")
    write_exr(tmp_path / "c.exr", layers(h=20))
    with pytest.raises(InputError, match=r"a\.exr is 32x24 but .*c\.exr is 32x20.*the same size"):
        compare_layers(tmp_path / "a.exr", tmp_path / "c.exr")
    with pytest.raises(InputError, match=r"nope\.exr: no such image file"):
        compare_layers(tmp_path / "a.exr", tmp_path / "nope.exr")
    with pytest.raises(InputError, match=r"layer 'rgb' has shape \(4, 4, 2\)"):
        compare_layers(np.zeros((4, 4, 2)), np.zeros((4, 4, 2)))


def test_bad_limits_are_named():
    a = layers()
    with pytest.raises(InputError, match=r"max_rel_rms names layer\(s\) \['shadow'\].*caustic, direct"):
        compare_layers(a, a, max_rel_rms={"shadow": 0.1})
    with pytest.raises(InputError, match=r"max_flip is -1.0; give a number >= 0"):
        compare_layers(a, a, max_flip=-1)
    with pytest.raises(InputError, match=r"max_flip for layer 'caustic' is nan"):
        compare_layers(a, a, max_flip={"caustic": float("nan")})
    with pytest.raises(InputError, match=r"max_rms is 'big'; give a number"):
        compare_layers(a, a, max_rms="big")


def test_flip_sees_a_visible_change_and_ignores_the_exposure():
    rng = np.random.default_rng(4)
    b = np.full((48, 48, 3), 0.2, np.float32) + 0.01 * rng.random((48, 48, 3), np.float32)
    a = b.copy()
    a[16:32, 16:32] *= 0.3                       # a dark square: plain to see
    faint = b.copy()
    faint[16:32, 16:32] *= 0.98                  # 2 %: hard to see
    strong, weak = flip_map(a, b), flip_map(faint, b)
    assert strong[24, 24] > 0.3 and strong.mean() > 5 * weak.mean()
    assert strong[2, 2] < 0.05                   # far from the square, no error
    # One exposure for both (B's white point): scaling both images leaves FLIP unchanged,
    # and an image twice as bright as its reference does not tone-map to the same picture.
    assert flip_map(10 * a, 10 * b) == pytest.approx(strong, abs=2e-3)
    assert flip_map(0.5 * b, b).mean() > 0.1


def test_compare_images_keeps_its_short_form(tmp_path):
    a, b = layers(seed=1), layers(seed=2)
    write_exr(tmp_path / "a.exr", a)
    write_exr(tmp_path / "b.exr", b)
    out = compare_images(tmp_path / "a.exr", tmp_path / "b.exr", diff_path=tmp_path / "d.exr")
    assert set(out) == {"direct", "caustic"} and out["direct"]["rms"] > 0
    diff = read_layers(tmp_path / "d.exr")
    assert np.allclose(diff["direct"], np.abs(a["direct"] - b["direct"]), atol=1e-6)


def test_png_alpha_is_left_out_and_grey_images_compare_as_rgb(tmp_path):
    spec = oiio.ImageSpec(8, 6, 4, oiio.UINT8)
    rgba = np.zeros((6, 8, 4), np.uint8)
    rgba[..., 3] = 255                       # opaque everywhere
    rgba[:3, :, 0] = 200                     # red in the top half only
    out = oiio.ImageOutput.create(str(tmp_path / "m.png"))
    assert out.open(str(tmp_path / "m.png"), spec) and out.write_image(rgba)
    out.close()
    assert read_layers(tmp_path / "m.png")["rgb"].shape == (6, 8, 3)
    a = {"rgb": np.zeros((6, 8, 3), np.float32)}
    b = {"rgb": np.zeros((6, 8, 3), np.float32)}
    a["rgb"][3:] = 1.0                       # differs only where the mask is black
    r = compare_layers(a, b, max_rms=0.0, mask=str(tmp_path / "m.png"))
    assert r.passed and r.mask.sum() == 24
    grey = oiio.ImageBuf(oiio.ImageSpec(8, 6, 1, oiio.FLOAT))
    grey.write(str(tmp_path / "g.exr"))
    assert compare_layers(tmp_path / "g.exr", b).metrics["rgb"]["rms"] == 0


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_the_image_writers_refuse_non_finite_values(tmp_path, value):
    from blockhash.errors import NonFiniteError
    from blockhash.evaluate.images import write_exr, write_png

    image = np.ones((6, 8, 3), np.float32)
    image[5, 7, 2] = value
    with pytest.raises(NonFiniteError, match=r"write_exr .*a.exr: the caustic layer has 1 "
                                             r"non-finite pixel .* first at x=7, y=5; nothing was written"):
        write_exr(tmp_path / "a.exr", {"direct": np.ones((6, 8, 3)), "caustic": image})
    with pytest.raises(NonFiniteError, match=r"write_png .*a.png: the image layer has 1"):
        write_png(tmp_path / "a.png", image)
    assert not list(tmp_path.iterdir())
