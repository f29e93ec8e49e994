"""One-sided receivers in the scene formats: the TOML key ``sided``, Mitsuba's bare
``diffuse`` (one-sided), ``twosided`` wrapper and ``flip_normals``, and the export that
writes them back so that Mitsuba reads the same faces."""

from pathlib import Path

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.scene.loader import load_scene
from blockhash.scene.materials import PhongMaterial, one_sided
from blockhash.scene.mitsuba.exporter import export_mitsuba, scene_xml

SCENE = """
[camera]
eye = [0.0, 2.0, 2.0]
target = [0.0, 0.0, 0.0]
fov_y_deg = 40.0
width = 16
height = 12

[materials.front]
kind = "phong"
kd = 0.5
{front}

[materials.both]
kind = "phong"
kd = [0.2, 0.3, 0.4]
{both}

[[lights]]
kind = "point"
position = [0.0, 1.0, 0.0]
power = 10.0

[[objects]]
name = "floor"
material = "front"
[objects.shape]
kind = "rectangle"
x = [-1.0, 1.0]
z = [-1.0, 1.0]

[[objects]]
name = "shelf"
material = "both"
[objects.shape]
kind = "rectangle"
x = [-0.2, 0.2]
z = [-0.2, 0.2]
y = 0.5
"""


def toml_scene(tmp_path, front='sided = "one"', both=""):
    path = tmp_path / "s.toml"
    path.write_text(SCENE.format(front=front, both=both))
    return load_scene(path)


def mitsuba_file(tmp_path, shape_inner: str) -> Path:
    path = tmp_path / "s.xml"
    path.write_text(f"""<scene version="3.0.0">
  <sensor type="perspective">
    <transform name="to_world"><lookat origin="0, 2, 2" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="12"/></film>
  </sensor>
  <emitter type="point"><point name="position" value="0, 1, 0"/></emitter>
  <shape type="rectangle">{shape_inner}</shape>
</scene>
""")
    return path


def test_a_phong_material_is_two_sided_unless_it_says_one():
    assert PhongMaterial(kd=0.5, ks=0.0, n=0.0).sided == "two"
    m = PhongMaterial(kd=0.5, ks=0.0, n=0.0, sided="one")
    assert m.one_sided and "sided='one'" in repr(m)
    with pytest.raises(InputError, match=r"PhongMaterial.sided: expected one of 'one', 'two'; "
                                         r"got 'front'; \"one\" reflects on the front face only"):
        PhongMaterial(kd=0.5, ks=0.0, n=0.0, sided="front")


def test_the_toml_key_sided_chooses_the_faces_and_two_is_the_default(tmp_path):
    scene = toml_scene(tmp_path)
    assert [o.material.sided for o in scene.objects] == ["one", "two"]
    assert list(one_sided(scene.objects)) == [True, False, False]  # and "nothing hit"
    assert "one-sided" in scene.summary().splitlines()[3]
    assert "one-sided" not in scene.summary().splitlines()[4]
    assert toml_scene(tmp_path, front="", both='sided = "two"').objects[0].material.sided == "two"


@pytest.mark.parametrize("value, got", [('"both"', "'both'"), ("1", "1")])
def test_a_bad_sided_names_the_file_and_key(tmp_path, value, got):
    with pytest.raises(InputError, match=rf"s\.toml: materials\.front\.sided: expected one of "
                                         rf"'one', 'two'; got {got}"):
        toml_scene(tmp_path, front=f"sided = {value}")


def test_sided_is_a_phong_key_only(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(SCENE.format(front="", both="").replace(
        'kind = "phong"\nkd = [0.2, 0.3, 0.4]', 'kind = "mirror"\nreflectance = 0.9\nsided = "one"'))
    with pytest.raises(InputError, match=r"materials\.both.*sided"):
        load_scene(path)


@pytest.mark.parametrize("inner, sided, up", [
    ('<bsdf type="diffuse"/>', "one", 1.0),
    ('<bsdf type="twosided"><bsdf type="diffuse"/></bsdf>', "two", 1.0),
    ('<boolean name="flip_normals" value="true"/><bsdf type="diffuse"/>', "one", -1.0),
    ('<boolean name="flip_normals" value="true"/><bsdf type="twosided"><bsdf type="diffuse"/>'
     '</bsdf>', "two", -1.0),
])
def test_mitsubas_diffuse_is_one_sided_twosided_two_and_flip_normals_turns_the_front(
        tmp_path, inner, sided, up):
    obj = load_scene(mitsuba_file(tmp_path, inner)).objects[0]
    assert obj.material.sided == sided
    # the rectangle faces +z; flip_normals turns its winding, so its front face, to -z
    np.testing.assert_allclose(obj.mesh.face_normals, [[0.0, 0.0, up]] * 2, atol=1e-12)
    np.testing.assert_allclose(obj.mesh.vertex_normals, [[0.0, 0.0, up]] * 4, atol=1e-12)


def test_a_bsdf_by_reference_keeps_its_faces(tmp_path):
    path = mitsuba_file(tmp_path, '<ref id="w"/>')
    text = path.read_text().replace(
        "<emitter", '<bsdf type="twosided" id="w"><bsdf type="diffuse"/></bsdf>\n  <emitter')
    path.write_text(text)
    assert load_scene(path).objects[0].material.sided == "two"


@pytest.mark.parametrize("inner, match", [
    ('<bsdf type="twosided"><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf>',
     r"s\.xml:7: <bsdf type=\"twosided\">: a twosided inside a twosided; keep one"),
    ('<bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>',
     r"s\.xml:7: <bsdf type=\"twosided\">: expected one <bsdf> inside .* or two \(the front's, "
     r"then the back's\)"),
])
def test_twosided_that_blockhash_cannot_read_is_refused(tmp_path, inner, match):
    with pytest.raises(InputError, match=match):
        load_scene(mitsuba_file(tmp_path, inner))


def test_the_export_writes_twosided_for_two_sided_and_bare_diffuse_for_one_sided(tmp_path):
    text = scene_xml(toml_scene(tmp_path))
    assert ('<bsdf type="diffuse" id="floor-bsdf">\n    <rgb name="reflectance" '
            'value="0.5, 0.5, 0.5"/>\n</bsdf>') in text
    assert ('<bsdf type="twosided" id="shelf-bsdf">\n    <bsdf type="diffuse">\n        '
            '<rgb name="reflectance" value="0.2, 0.3, 0.4"/>\n    </bsdf>\n</bsdf>') in text


@pytest.mark.parametrize("front, both", [('sided = "one"', ""), ("", 'sided = "one"'),
                                         ('sided = "two"', 'sided = "two"')])
def test_export_then_import_keeps_the_faces_each_material_reflects_on(tmp_path, front, both):
    scene = toml_scene(tmp_path, front=front, both=both)
    back = load_scene(export_mitsuba(scene, tmp_path / "out"))
    assert [o.material.sided for o in back.objects] == [o.material.sided for o in scene.objects]
    for a, b in zip(scene.objects, back.objects):
        np.testing.assert_array_equal(a.material.kd, b.material.kd)
        np.testing.assert_array_equal(a.mesh.faces, b.mesh.faces)  # the winding, so the front
