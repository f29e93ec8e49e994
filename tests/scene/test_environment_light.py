"""The environment light (blockhash/scene/environment_light.py): its radiance is Mitsuba's
``envmap``'s wherever it is looked up, its sampling is unbiased for a map with a sun and a black
band, its density is the one it draws with, and bad maps are refused by name; Mitsuba's files
read it (blockhash/scene/mitsuba/environment.py): filename through the search path, scale,
to_world, 8-bit images decoded from sRGB."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenImageIO as oiio
import pytest
from conftest import mitsuba_or_skip
from environment_maps import rotation, sky, sky_image

from blockhash.errors import InputError
from blockhash.scene.environment_light import EnvironmentLight
from blockhash.scene.loader import load_scene
from blockhash.scene.model import Scene


def directions(n: int, seed: int = 3) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_the_radiance_is_mitsubas_envmap_everywhere():
    mitsuba_or_skip()
    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, _ = load_mitsuba_module()
    light = sky()
    m = np.eye(4)
    m[:3, :3] = light.to_world
    theirs = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(light.image.astype(np.float32)),
                           "to_world": mi.ScalarTransform4f(m.tolist())})
    d = directions(5000)
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*(-d.T.astype(np.float32)))
    ref = np.asarray(theirs.eval(si), dtype=np.float64).reshape(3, -1).T
    ours = light.emitted(d)
    assert np.allclose(ours, ref, rtol=1e-4, atol=1e-4 * ref.max())


@pytest.mark.parametrize("two_uniforms", [False, True], ids=["three uniforms", "two uniforms"])
def test_the_sampling_is_unbiased_and_draws_with_its_own_density(two_uniforms):
    light = sky()
    u = np.random.default_rng(11).random((400_000, 3))
    toward, pdf = light.sample(u[:, 0], None if two_uniforms else u[:, 1], u[:, 2])
    assert np.allclose(np.linalg.norm(toward, axis=1), 1.0)
    assert np.all(pdf > 0)
    assert np.allclose(light.pdf(toward), pdf, rtol=1e-6)
    f = light.emitted(toward) / pdf[:, None]
    estimate, error = f.mean(axis=0), f.std(axis=0) / np.sqrt(len(f))
    # the exact integral of the bilinear map: a fine quadrature in (u, cos theta)
    grid = 1200
    uu, cc = np.meshgrid((np.arange(2 * grid) + 0.5) / (2 * grid), 1 - (np.arange(grid) + 0.5) / grid * 2)
    s = np.sqrt(1 - cc ** 2)
    phi = 2 * np.pi * uu
    v = np.stack([np.sin(phi) * s, cc, -np.cos(phi) * s], axis=-1).reshape(-1, 3)
    exact = light.emitted(v @ light.to_world.T).mean(axis=0) * 4 * np.pi
    assert np.all(np.abs(estimate - exact) < 5 * error + 2e-3 * exact), (estimate, exact, error)
    # importance: the sun (a 200x brighter patch of 4 pixels) takes most of the samples
    assert np.mean(light.emitted(toward).max(axis=1) > 50) > 0.3


def test_the_integral_and_the_turn():
    plain, turned = EnvironmentLight(sky_image()), sky()
    assert np.allclose(plain.integral, turned.integral)
    d = directions(100)
    assert np.allclose(turned.emitted(d @ rotation().T), plain.emitted(d))


@pytest.mark.parametrize("bad, match", [
    (lambda img: img * -1.0, "values below 0"),
    (lambda img: np.where(img > 100, np.nan, img), "not finite"),
    (lambda img: img * 0.0, "black"),
    (lambda img: img[:2], "at least 2 x 3"),
    (lambda img: img[..., :2], "RGB radiance"),
])
def test_a_bad_map_is_refused_by_name(bad, match):
    with pytest.raises(InputError, match=match):
        EnvironmentLight(bad(sky_image()))


def test_a_transform_that_is_not_a_rotation_is_refused():
    with pytest.raises(InputError, match="to_world: expected a rotation"):
        EnvironmentLight(sky_image(), np.diag([2.0, 2.0, 2.0]))
    with pytest.raises(InputError, match="to_world: expected a rotation"):
        EnvironmentLight(sky_image(), np.diag([1.0, 1.0, -1.0]))


def test_a_scene_takes_one_environment(tmp_path):
    scene = load_scene(_xml(tmp_path, '<string name="filename" value="sky.exr"/>'))
    with pytest.raises(InputError, match="a second environment light"):
        Scene(camera=scene.camera, lights=(sky(), sky()), objects=scene.objects)
    assert "light   environment 'sky.exr', 32 x 17 pixels" in scene.summary()


def _write(path, image, fmt=oiio.FLOAT):
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(image.shape[1], image.shape[0], image.shape[2], fmt))
    out.write_image(np.ascontiguousarray(image.astype(np.float32 if fmt == oiio.FLOAT else np.uint8)))
    out.close()


def _xml(tmp_path, props: str, image=None, name="sky.exr", folder="maps") -> str:
    (tmp_path / folder).mkdir(exist_ok=True)
    if image is None:
        _write(tmp_path / folder / "sky.exr", sky_image())
    path = tmp_path / "scene.xml"
    path.write_text(f"""<scene version="3.0.0">
  <path value="{folder}"/>
  <sensor type="perspective"><transform name="to_world">
    <lookat origin="0, 1, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/>
    <rfilter type="box"/></film></sensor>
  <emitter type="envmap">{props}</emitter>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"/></shape>
</scene>""")
    return path


def test_mitsubas_envmap_is_read_with_its_scale_and_turn(tmp_path):
    path = _xml(tmp_path, '<string name="filename" value="sky.exr"/><float name="scale" value="3"/>'
                '<boolean name="mis_compensation" value="true"/>'
                '<transform name="to_world"><rotate y="1" angle="90"/></transform>')
    (light,) = load_scene(path).lights
    assert np.allclose(light.image, 3 * sky_image(), rtol=1e-3)  # float32 on file
    assert np.allclose(light.to_world @ [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], atol=1e-6)


def test_an_8_bit_map_is_decoded_from_srgb(tmp_path):
    (tmp_path / "maps").mkdir()
    img = np.full((4, 8, 3), 128, np.uint8)
    img[0] = 255
    _write(tmp_path / "maps" / "sky.png", img, oiio.UINT8)
    (light,) = load_scene(_xml(tmp_path, '<string name="filename" value="sky.png"/>', image=img)).lights
    assert np.allclose(light.image[1, 0], ((128 / 255 + 0.055) / 1.055) ** 2.4, rtol=1e-3)
    assert np.allclose(light.image[0, 0], 1.0)


@pytest.mark.parametrize("props, match", [
    ('<string name="filename" value="nowhere.exr"/>',
     r"scene.xml:7: <emitter type=\"envmap\">: environment map not found: 'nowhere.exr', looked for at"),
    ("", r"scene.xml:7: <emitter type=\"envmap\">: an envmap needs its image"),
    ('<string name="filename" value="sky.exr"/><float name="scale" value="-1"/>',
     "scale -1: an environment map's scale must be > 0"),
    ('<string name="filename" value="sky.exr"/><transform name="to_world"><scale value="2"/>'
     '</transform>', "to_world: expected a rotation"),
    ('<string name="filename" value="sky.exr"/><rgb name="radiance" value="1"/>',
     "radiance.*unsupported here"),
])
def test_a_bad_envmap_element_names_its_line(tmp_path, props, match):
    with pytest.raises(InputError, match=match):
        load_scene(_xml(tmp_path, props))


def test_an_exported_environment_reads_back_the_same(tmp_path):
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    scene = load_scene(_xml(tmp_path, '<string name="filename" value="sky.exr"/>'
                       '<transform name="to_world"><rotate x="1" y="1" angle="30"/></transform>'))
    xml = export_mitsuba(scene, tmp_path / "out", integrator="path")
    assert '<emitter type="envmap">' in xml.read_text()
    (back,) = load_scene(xml).lights
    (light,) = scene.lights
    assert np.array_equal(back.image, light.image.astype(np.float32))
    assert np.allclose(back.to_world, light.to_world, atol=1e-6)


def test_a_scene_file_takes_an_environment_light(tmp_path):
    _write(tmp_path / "sky.exr", sky_image())
    text = (Path(__file__).resolve().parents[2] / "scenes" / "ring.toml").read_text()
    head, rest = text.split("[[lights]]", 1)
    rest = rest.split("\n\n", 1)[1] if "\n\n" in rest else ""
    path = tmp_path / "lit.toml"
    path.write_text(head + '[[lights]]\nkind = "environment"\nfile = "sky.exr"\nscale = 2.0\n'
                    'rotate_deg = [0.0, 90.0, 0.0]\n\n' + rest)
    scene = load_scene(path)
    (light,) = [li for li in scene.lights if isinstance(li, EnvironmentLight)]
    assert np.allclose(light.image, 2 * sky_image(), rtol=1e-6)
    assert np.allclose(light.to_world @ [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], atol=1e-12)
    path.write_text(path.read_text().replace('file = "sky.exr"', 'file = "nowhere.exr"'))
    with pytest.raises(InputError, match=r"lights\[0\]\.file: image not found"):
        load_scene(path)
