"""Mitsuba 3 XML: export then import gives back the same scene, and bad files name the element
and its line."""

import math
from pathlib import Path

import numpy as np
import pytest

from blockhash.cli import main
from blockhash.errors import InputError
from blockhash.reference.mitsuba import mitsuba_available, without_specular_lobes
from blockhash.scene.loader import load_scene
from blockhash.scene.mitsuba.exporter import export_mitsuba, scene_xml
from blockhash.scene.model import AreaLight, DielectricMaterial, MirrorMaterial, PhongMaterial, SpotLight

SCENES = Path(__file__).resolve().parents[3] / "scenes"
SHIPPED = sorted(SCENES.glob("*.toml"))


def assert_same_scene(a, b):
    for f in ("eye", "target", "up"):
        np.testing.assert_allclose(getattr(a.camera, f), getattr(b.camera, f), atol=1e-12)
    assert (a.camera.width, a.camera.height, a.camera.spp) == (b.camera.width, b.camera.height,
                                                               b.camera.spp)
    assert a.camera.fov_y_deg == pytest.approx(b.camera.fov_y_deg, abs=1e-12)
    assert a.photons == b.photons and a.description == b.description
    assert len(a.lights) == len(b.lights)
    for la, lb in zip(a.lights, b.lights):
        assert type(la) is type(lb)
        # an area light's power comes from its mesh's area: float32 in PLY
        if hasattr(la, "power"):
            np.testing.assert_allclose(la.power, lb.power,
                                       rtol=1e-6 if isinstance(la, AreaLight) else 1e-12)
        for attr in ("position", "direction", "radiance", "irradiance"):
            if hasattr(la, attr):
                np.testing.assert_allclose(getattr(la, attr), getattr(lb, attr), atol=1e-12)
        if isinstance(la, SpotLight):
            assert la.cone_deg == pytest.approx(lb.cone_deg, abs=1e-12)
        if isinstance(la, AreaLight):
            assert la.object == lb.object
    assert [o.name for o in a.objects] == [o.name for o in b.objects]
    for oa, ob in zip(a.objects, b.objects):
        ma, mb = oa.material, ob.material
        assert type(ma) is type(mb)
        if isinstance(ma, PhongMaterial):
            np.testing.assert_array_equal(ma.kd, mb.kd)
            np.testing.assert_array_equal(ma.ks, mb.ks)
            assert ma.sided == mb.sided, oa.name
        elif isinstance(ma, MirrorMaterial):
            np.testing.assert_array_equal(ma.reflectance, mb.reflectance)
        else:
            assert ma.ior == mb.ior
            np.testing.assert_array_equal(ma.tint, mb.tint)
        np.testing.assert_array_equal(oa.mesh.faces, ob.mesh.faces)
        # PLY stores float32: positions and normals come back to float32 rounding
        scale = np.abs(oa.mesh.vertices).max()
        np.testing.assert_allclose(oa.mesh.vertices, ob.mesh.vertices, atol=scale * 2**-23)
        np.testing.assert_allclose(oa.mesh.vertex_normals, ob.mesh.vertex_normals, atol=1e-6)


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_export_then_import_gives_back_every_shipped_scene(path, tmp_path):
    scene = load_scene(path)
    xml = export_mitsuba(scene, tmp_path, drop_specular=True)
    back = load_scene(xml)
    assert_same_scene(without_specular_lobes(scene), back)
    glossy = any(isinstance(o.material, PhongMaterial) and np.any(o.material.ks > 0)
                 for o in scene.objects)
    # a floor with ks > 0 loses its lobe, and the file says so; a Lambertian one loses nothing
    assert ("is dropped" in xml.read_text()) == glossy


def test_a_specular_lobe_is_an_error_naming_the_material_and_the_flag(tmp_path):
    scene = load_scene(SCENES / "ring.toml")
    with pytest.raises(InputError, match=r"object 'floor'.*ks = .*drop_specular=True"):
        export_mitsuba(scene, tmp_path / "out")
    assert not (tmp_path / "out").exists()  # nothing written
    assert main(["export", str(SCENES / "ring.toml"), "--to", "mitsuba", "-o", str(tmp_path / "o")]) == 2


def test_the_export_command_writes_xml_and_meshes(tmp_path, capsys):
    out = tmp_path / "glass"
    assert main(["export", str(SCENES / "glass.toml"), "--to", "mitsuba", "-o", str(out),
                 "--drop-specular"]) == 0
    assert (out / "scene.xml").is_file() and (out / "meshes" / "ball.ply").is_file()
    assert "scene.xml" in capsys.readouterr().out
    text = (out / "scene.xml").read_text()
    assert 'type="dielectric"' in text and 'name="int_ior" value="1.5"' in text


def write(tmp_path, body: str) -> Path:
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0">\n<sensor type="perspective">\n'
                 '  <float name="fov" value="40"/>\n'
                 '  <transform name="to_world"><lookat origin="0, 1, 3" target="0, 0, 0" up="0, 1, 0"/></transform>\n'
                 '  <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="32"/></film>\n'
                 '</sensor>\n' + body + "</scene>\n")
    return p


LIGHT = '<emitter type="point"><point name="position" x="0" y="2" z="0"/><rgb name="intensity" value="1"/></emitter>\n'


def test_hand_written_shapes_transforms_and_fov_axis(tmp_path):
    body = ('<bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.5"/></bsdf>\n'
            '<bsdf type="twosided" id="chrome"><bsdf type="conductor"><string name="material" value="none"/></bsdf></bsdf>\n'
            + LIGHT +
            '<shape type="rectangle" id="floor"><transform name="to_world"><rotate x="1" angle="-90"/>'
            '<scale value="2"/><translate y="-0.5"/></transform><ref id="white"/></shape>\n'
            '<shape type="sphere"><point name="center" x="0" y="0.3" z="0"/><float name="radius" value="0.3"/>'
            '<bsdf type="dielectric"><float name="int_ior" value="1.33"/></bsdf></shape>\n'
            '<shape type="cube"><transform name="to_world"><scale value="0.1"/></transform><ref id="chrome"/></shape>\n')
    scene = load_scene(write(tmp_path, body))
    floor, ball, cube = scene.objects
    assert (floor.name, ball.name, cube.name) == ("floor", "sphere-1", "cube-2")
    # rotate -90 about x takes the rectangle's +z normal to +y; scale 2; then down 0.5
    np.testing.assert_allclose(floor.mesh.vertex_normals, np.tile([0, 1, 0], (4, 1)), atol=1e-12)
    np.testing.assert_allclose(floor.mesh.bounds, [[-2, -0.5, -2], [2, -0.5, 2]], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(ball.mesh.vertices - [0, 0.3, 0], axis=1), 0.3)
    np.testing.assert_allclose(cube.mesh.bounds, [[-0.1] * 3, [0.1] * 3], atol=1e-12)
    assert isinstance(ball.material, DielectricMaterial) and ball.material.ior == 1.33
    assert isinstance(cube.material, MirrorMaterial)
    np.testing.assert_allclose(scene.lights[0].power, 4 * math.pi)
    c = scene.camera  # fov 40 on x (Mitsuba's default axis) of a 64 x 32 film
    assert math.tan(math.radians(c.fov_y_deg) / 2) == pytest.approx(math.tan(math.radians(20)) / 2)


@pytest.mark.parametrize("body, match", [
    ('<emitter type="area"/>\n', r"s.xml:7: <emitter type=\"area\">: an area emitter belongs inside a <shape>"),
    ('<emitter type="arae"/>\n', r"s.xml:7: <emitter type=\"arae\">: unsupported emitter; supported: point, spot, directional"),
    ('<shape type="sdfgrid"/>\n', r"s.xml:7: <shape type=\"sdfgrid\">: unsupported shape; supported: ply"),
    ('<bsdf type="pplastic" id="x"/>\n', r"s.xml:7: .*unsupported BSDF; supported: diffuse"),
    ('<bsdf type="conductor" id="cu"><string name="material" value="Cuu"/></bsdf>\n', r"s.xml:7: .*material 'Cuu' is not one of Mitsuba's conductor presets \(a-C, Ag, .*give eta and k"),
    ('<bsdf type="conductor" id="cu"><string name="material" value="Cu"/><float name="eta" value="1"/></bsdf>\n', r"s.xml:7: .*either a material preset or eta and k, not both"),
    (LIGHT + '<shape type="ply"><string name="filename" value="gone.ply"/><bsdf type="diffuse"/></shape>\n',
     r"s.xml:8: <shape type=\"ply\">: mesh file not found: .*gone.ply"),
    (LIGHT + '<shape type="rectangle"><ref id="nowhere"/></shape>\n', r"s.xml:8: <ref>: no BSDF with id 'nowhere'"),
    ('<medium type="homogeneous"/>\n', r"s.xml:7: <medium type=\"homogeneous\">: unsupported element"),
    ('<emitter type="spot"><float name="cutoff_angle" value="30"/><float name="beam_width" value="40"/></emitter>\n',
     r"beam_width 40 exceeds cutoff_angle 30"),
    (LIGHT + '<shape type="rectangle"><float name="radius" value="1"/><bsdf type="diffuse"/></shape>\n',
     r"s.xml:8: <float name=\"radius\">: unsupported here"),
])
def test_unsupported_input_names_the_element_and_its_line(tmp_path, body, match):
    with pytest.raises(InputError, match=match):
        load_scene(write(tmp_path, body))


@pytest.mark.parametrize("text, where, what", [
    ("<scene><sensor></scene>", "1:18", "mismatched tag"),
    ('<scene version="3.0.0">\n  <shape type="rectangle">\n</scene>\n', "3:3", "mismatched tag"),
    ('<scene version="3.0.0">\n  <bsdf type="diffuse">\n', "3:1", "no element found|unclosed token"),
    ("", "1:1", "no element found"),
])
def test_an_xml_syntax_error_names_file_line_and_column(tmp_path, text, where, what):
    """file:line:col, as every other import error names file:line, so that editors and
    terminals turn it into a link."""
    p = tmp_path / "bad.xml"
    p.write_text(text)
    with pytest.raises(InputError, match=rf"bad\.xml:{where}: XML syntax error: ({what})") as e:
        load_scene(p)
    assert "fix the file there" in str(e.value)


def test_spot_lights_keep_power_cone_and_direction(tmp_path):
    scene = load_scene(SCENES / "ring.toml")
    from dataclasses import replace
    spot = SpotLight(position=[0.0, 2.0, 0.5], direction=[0.2, -1.0, 0.0], power=50.0, cone_deg=25.0)
    scene = without_specular_lobes(replace(scene, lights=(spot,)))
    back = load_scene(export_mitsuba(scene, tmp_path))
    assert_same_scene(scene, back)


@pytest.mark.skipif(not mitsuba_available()[0], reason=mitsuba_available()[1])
@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_mitsuba_loads_every_exported_scene_unchanged(path, tmp_path):
    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, _ = load_mitsuba_module()
    xml = export_mitsuba(load_scene(path), tmp_path, drop_specular=True)
    loaded = mi.load_file(str(xml))
    scene = load_scene(path)
    # Mitsuba merges meshes that share a BSDF into one: count triangles, and the emitters
    assert sum(s.face_count() for s in loaded.shapes()) == sum(len(o.mesh.faces)
                                                              for o in scene.objects)
    assert len(loaded.emitters()) == len(scene.lights)
    assert scene_xml(load_scene(path), drop_specular=True) == xml.read_text()
