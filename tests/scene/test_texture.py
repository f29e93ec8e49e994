"""Image textures (blockhash/scene/texture.py): the lookup is Mitsuba's ``bitmap`` texture's in
every wrap and filter mode; a textured receiver scales each shading point's weight by the
texture there over its mean and gives indirect photons the texture as their albedo, on the
host and on the Dr.Jit kernels alike; bad textures are refused by name."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import mitsuba_or_skip

from blockhash.errors import InputError
from blockhash.scene.loader import load_scene
from blockhash.scene.model import PhongMaterial, SceneObject
from blockhash.scene.texture import FILTERS, WRAPS, Texture

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def image(h: int = 5, w: int = 7, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).random((h, w, 3))


@pytest.mark.parametrize("filt", FILTERS)
@pytest.mark.parametrize("wrap", WRAPS)
def test_the_lookup_is_mitsubas_bitmap(wrap, filt):
    mitsuba_or_skip()
    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, _ = load_mitsuba_module()
    img = image()
    to_uv = np.array([[1.5, 0.2, 0.1], [-0.3, 2.0, 0.25]])
    m = np.eye(4)
    m[:2, :2], m[:2, 3] = to_uv[:, :2], to_uv[:, 2]
    theirs = mi.load_dict({"type": "bitmap", "bitmap": mi.Bitmap(img.astype(np.float32)),
                           "wrap_mode": wrap, "filter_type": filt, "raw": True,
                           "to_uv": mi.ScalarTransform4f(m.tolist())})
    uv = np.random.default_rng(1).uniform(-1.5, 2.5, size=(3000, 2))
    si = mi.SurfaceInteraction3f()
    si.uv = mi.Point2f(*uv.T.astype(np.float32))
    ref = np.asarray(theirs.eval(si), dtype=np.float64).reshape(3, -1).T
    ours = Texture(img, to_uv, wrap=wrap, filter=filt).value(uv)
    # float32 coordinates there: a nearest lookup may round across a pixel border
    close = np.abs(ours - ref).max(axis=1) < 1e-4
    assert close.mean() > (0.999 if filt == "nearest" else 1.0 - 1e-9)


@pytest.mark.parametrize("bad, match", [
    (lambda img: img * 2.0, "values must lie in \\[0, 1\\]"),
    (lambda img: np.where(img > 0.9, np.nan, img), "values must lie in \\[0, 1\\]"),
    (lambda img: img[..., :2], "expected \\(height, width, 3\\) RGB"),
])
def test_a_bad_texture_is_refused_by_name(bad, match):
    with pytest.raises(InputError, match=f"Texture 'texture'.image: .*{match}"):
        Texture(bad(image()))
    with pytest.raises(InputError, match="wrap: expected one of repeat, mirror, clamp"):
        Texture(image(), wrap="tile")


def _textured(scene, texture: Texture, names=None):
    """``scene`` with its diffuse objects (or those of ``names``) textured, their texture
    coordinates the vertices' (x, z) over the scene's extent."""
    lo, hi = scene.bounds
    objects = []
    for o in scene.objects:
        if o.is_specular or (names is not None and o.name not in names):
            objects.append(o)
            continue
        v = np.asarray(o.mesh.vertices)
        uv = (v[:, [0, 2]] - lo[[0, 2]]) / (hi - lo)[[0, 2]]
        material = PhongMaterial(kd=texture.mean, ks=0.0, n=0.0, sided=o.material.sided,
                                 texture=texture)
        objects.append(SceneObject(o.name, o.mesh, material, uv=uv))
    return replace(scene, objects=tuple(objects))


def test_a_textured_point_takes_the_texture_over_its_mean():
    """Every point on the textured floor, seen directly or in the ring's mirror, carries the
    plain floor's path weight times the texture there over its mean."""
    from blockhash.frame.camera_samples import camera_points
    from blockhash.frame.scene_rays import SceneRays

    texture = Texture(image(6, 9), wrap="clamp")
    plain = load_scene(SCENES / "ring.toml").with_size(48, 36)
    scene = _textured(plain, texture, {"floor"})
    points, _ = camera_points(scene, SceneRays(scene.objects), 1)
    before, _ = camera_points(plain, SceneRays(plain.objects), 1)
    floor = [o.name for o in scene.objects].index("floor")
    on = points.material == floor
    assert on.mean() > 0.2 and np.array_equal(on, before.material == floor)
    lo, hi = scene.bounds
    p = points.position[on].astype(np.float64)
    want = texture.value((p[:, [0, 2]] - lo[[0, 2]]) / (hi - lo)[[0, 2]]) / texture.mean
    assert np.allclose(points.weight[on], before.weight[on] * want, rtol=1e-3, atol=1e-4)
    assert (before.weight[on] < 0.99).any()  # some are seen in the mirror


def test_the_kernels_indirect_photons_take_the_texture_as_the_host_does():
    from blockhash.device.choice import resolve
    from blockhash.photons.indirect import IndirectSource
    from blockhash.scene.raycast import EmbreeGeometry

    try:
        resolve("cpu")
    except InputError as exc:
        pytest.skip(f"no Dr.Jit CPU device here: {exc}")
    img = np.zeros((8, 8, 3))
    img[:, :4] = [0.9, 0.1, 0.1]  # half the floor red, half green
    img[:, 4:] = [0.1, 0.9, 0.1]
    scene = _textured(load_scene(SCENES / "cbox.toml"), Texture(img, wrap="clamp",
                                                               filter="nearest"), {"floor"})
    geometry = EmbreeGeometry(tuple(scene.objects))
    host = IndirectSource(scene, geometry, device="host").emit(200_000, seed=5)
    kern = IndirectSource(scene, geometry, device="cpu").emit(200_000, seed=5)
    box = load_scene(SCENES / "cbox.toml")
    plain = IndirectSource(box, EmbreeGeometry(tuple(box.objects)), device="host").emit(
        200_000, seed=5)
    ceiling = [o.name for o in scene.objects].index("ceiling")

    def stored(ph):
        w = ph.powers.astype(np.float64)[ph.objects == ceiling]
        return w.sum(axis=0), np.sqrt((w ** 2).sum(axis=0))

    (a, ea), (b, eb), (c, _) = stored(host), stored(kern), stored(plain)
    assert np.all(np.abs(a - b) < 4.5 * np.hypot(ea, eb) + 1e-3 * a), (a, b)
    # the floor's light on the ceiling is red and green, not the plain floor's white
    assert a[2] < 0.8 * c[2] and a[0] > 0.3 * a[2]


def test_a_textured_material_needs_coordinates_and_no_gloss():
    texture = Texture(image())
    scene = load_scene(SCENES / "ring.toml")
    floor = next(o for o in scene.objects if o.name == "floor")
    material = PhongMaterial(kd=texture.mean, ks=0.0, n=0.0, texture=texture)
    with pytest.raises(InputError, match="uv: a textured material needs the mesh's texture"):
        SceneObject("floor", floor.mesh, material)
    with pytest.raises(InputError, match="ks must be 0 with a texture"):
        PhongMaterial(kd=0.2, ks=0.1, n=5.0, texture=texture)
    with pytest.raises(InputError, match=r"uv: expected \(.*, 2\) finite texture coordinates"):
        SceneObject("floor", floor.mesh, material, uv=np.zeros((3, 2)))
