"""A bitmap texture in a Mitsuba file (blockhash/scene/mitsuba/textures.py): an 8-bit floor
texture, repeated twice by ``to_uv``, under an area light beside a plain wall, rendered by
blockhash and by Mitsuba from the same file: the direct light on the floor, the floor's colours
bounced onto the wall and back, within 2% of Mitsuba's flux and a blurred relative RMS of
0.05 (measured 0.8% and 0.036 at 48 pixels, 4 passes of 16 samples); a spot light's
projected texture (Mitsuba's spot ``texture``) on a floor and a wall, and an area light's
textured radiance seen and lighting a floor, the same limits (measured 0.0% and 0.003; 0.1%
and 0.013).

Needs the extra blockhash[mitsuba]; skipped without it, unless BLOCKHASH_REQUIRE_MITSUBA is
set (CI sets it), where it fails instead."""

from __future__ import annotations

import numpy as np
import OpenImageIO as oiio
import pytest
from conftest import mitsuba_or_skip

from blockhash.studies.published import compare, load

#: The scenes' integrator and camera (64 x 48, 16 samples a pixel, a box filter).
HEAD = """<scene version="3.0.0">
 <integrator type="path"/>
 <sensor type="perspective"><float name="fov" value="{fov}"/>
  <transform name="to_world"><lookat origin="{origin}" target="{target}" up="0, 1, 0"/></transform>
  <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
  <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
  <rfilter type="box"/></film></sensor>
"""
SCENE = HEAD.format(fov=45, origin="0, 2.5, 5", target="0, 0.3, 0") + """ <shape type="sphere"><point name="center" x="-1.5" y="3" z="1"/><float name="radius" value="0.25"/>
  <emitter type="area"><rgb name="radiance" value="20"/></emitter></shape>
 <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/></transform>
  <bsdf type="diffuse"><texture name="reflectance" type="bitmap"><string name="filename" value="floor.png"/>
   <transform name="to_uv"><scale x="2" y="2"/></transform></texture></bsdf></shape>
 <shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-2"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.7"/></bsdf></shape>
</scene>"""


def floor_texture() -> np.ndarray:
    """(24, 32, 3) uint8: red across, green down, blue checks of 4 pixels."""
    y, x = np.mgrid[0:24, 0:32]
    img = np.stack([0.15 + 0.7 * x / 32, 0.15 + 0.7 * y / 24,
                    np.where((x // 4 + y // 4) % 2 == 0, 0.8, 0.1)], axis=-1)
    return (img * 255).astype(np.uint8)


@pytest.fixture
def textured(tmp_path):
    out = oiio.ImageOutput.create(str(tmp_path / "floor.png"))
    out.open(str(tmp_path / "floor.png"), oiio.ImageSpec(32, 24, 3, oiio.UINT8))
    out.write_image(floor_texture())
    out.close()
    (tmp_path / "floor.xml").write_text(SCENE)
    return tmp_path / "floor.xml"


def test_the_bitmap_is_read_with_its_coordinates(textured):
    scene, refused, warned = load(textured)
    assert refused is None and not warned
    floor = scene.objects[1]
    t = floor.material.texture
    assert t is not None and t.image.shape == (24, 32, 3) and t.wrap == "repeat"
    srgb = floor_texture()[0, 0, 0] / 255.0
    assert np.isclose(t.image[0, 0, 0], ((srgb + 0.055) / 1.055) ** 2.4)  # decoded from sRGB
    assert np.allclose(t.to_uv, [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0]])
    assert floor.uv.shape == (len(floor.mesh.vertices), 2)
    assert np.allclose(floor.material.kd, t.mean)


@pytest.mark.gl
@pytest.mark.slow
def test_a_textured_floor_renders_as_mitsuba_renders_it(textured):
    mitsuba_or_skip()
    row = compare(textured, size=48, spp=4096, passes=4, samples=16)
    assert row.refused is None
    assert np.all(np.abs(row.flux - 1) < 0.02), row.flux
    assert row.blurred < 0.05, row.blurred


def test_an_exported_texture_reads_back_the_same(textured, tmp_path):
    """The export writes the bitmap (linear, as an EXR) and the mesh's texture coordinates (the
    PLY's u and v): read back, the same texture at the same coordinates."""
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    scene, _, _ = load(textured)
    xml = export_mitsuba(scene, tmp_path / "out", integrator="path")
    back, refused, _ = load(xml)
    assert refused is None
    a, b = scene.objects[1], back.objects[1]
    assert np.allclose(b.material.texture.image, a.material.texture.image, atol=1e-6)
    assert np.allclose(b.material.texture.to_uv, a.material.texture.to_uv)
    assert b.material.texture.wrap == a.material.texture.wrap
    centres = np.asarray(a.mesh.vertices)
    order = [int(np.argmin(np.linalg.norm(np.asarray(b.mesh.vertices) - c, axis=1))) for c in centres]
    assert np.allclose(b.uv[order], a.uv, atol=1e-6)


SPOT = HEAD.format(fov=50, origin="0, 3, 4", target="0, 0, 0") + """ <emitter type="spot"><transform name="to_world"><lookat origin="-1, 3, 1" target="0, 0, 0" up="0, 0, 1"/></transform>
  <rgb name="intensity" value="20"/><float name="cutoff_angle" value="35"/><float name="beam_width" value="30"/>
  <texture name="texture" type="bitmap"><string name="filename" value="floor.png"/></texture></emitter>
 <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></shape>
 <shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-2"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
</scene>"""


@pytest.mark.gl
@pytest.mark.slow
def test_a_spot_lights_projected_texture_renders_as_mitsuba_renders_it(textured):
    mitsuba_or_skip()
    path = textured.parent / "spot.xml"
    path.write_text(SPOT)
    scene, refused, _ = load(path)
    assert refused is None and scene.lights[0].texture is not None
    assert np.allclose(scene.lights[0].frame[:, 2], scene.lights[0].direction)
    row = compare(path, size=48, spp=4096, passes=2, samples=16)
    assert np.all(np.abs(row.flux - 1) < 0.02), row.flux
    assert row.blurred < 0.05, row.blurred


def test_an_exported_spot_texture_reads_back_the_same(textured, tmp_path):
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    path = textured.parent / "spot.xml"
    path.write_text(SPOT)
    scene, _, _ = load(path)
    back, refused, _ = load(export_mitsuba(scene, tmp_path / "out", integrator="path"))
    assert refused is None
    a, b = scene.lights[0], back.lights[0]
    assert np.allclose(b.texture.image, a.texture.image, atol=1e-6)
    assert np.allclose(b.frame, a.frame, atol=1e-6) and np.allclose(b.position, a.position)
    d = np.random.default_rng(2).normal(size=(200, 3)) * 0.3 + a.direction
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    assert np.allclose(b.texture_factor(d), a.texture_factor(d), atol=1e-5)


AREA = HEAD.format(fov=50, origin="0, 3, 4", target="0, 0.5, 0") + """ <shape type="rectangle"><transform name="to_world"><scale x="1" y="0.7"/><rotate x="1" angle="20"/>
  <translate y="1" z="-1"/></transform><bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>
  <emitter type="area"><texture name="radiance" type="bitmap"><string name="filename" value="floor.png"/>
  </texture></emitter></shape>
 <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/></transform>
  <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></shape>
</scene>"""


@pytest.mark.gl
@pytest.mark.slow
def test_an_area_lights_textured_radiance_renders_as_mitsuba_renders_it(textured, tmp_path):
    """The emitter seen directly and its light on the floor (the emitter reflects nothing, so
    that the texture alone is tested), then the same scene exported and read back."""
    mitsuba_or_skip()
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    path = textured.parent / "area.xml"
    path.write_text(AREA)
    scene, refused, _ = load(path)
    assert refused is None
    light = scene.lights[0]
    assert light.texture is not None and light.uv.shape == (len(light.mesh.vertices), 2)
    assert np.allclose(light.radiance, light.texture.mean)
    row = compare(path, size=48, spp=4096, passes=2, samples=16)
    assert np.all(np.abs(row.flux - 1) < 0.02), row.flux
    assert row.blurred < 0.05, row.blurred
    back, refused, _ = load(export_mitsuba(scene, tmp_path / "out", integrator="path"))
    assert refused is None
    u = np.random.default_rng(4).random((3, 300))
    assert np.allclose(back.lights[0].emitted_at(*u), light.emitted_at(*u), atol=1e-5)
