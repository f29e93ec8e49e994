"""Mitsuba's ``roughconductor`` and ``roughdielectric`` read as rough mirrors and glass
(:mod:`blockhash.scene.mitsuba.bsdfs`), TOML's ``alpha`` and ``distribution`` on mirror and
dielectric materials, and the errors of what blockhash does not model (anisotropic or
textured roughness) or cannot take (a roughness out of range, an unknown distribution)."""

import numpy as np
import pytest
from test_mitsuba_mapping import load

from blockhash.errors import InputError
from blockhash.scene.loader import parse_scene
from blockhash.scene.materials import DielectricMaterial, MirrorMaterial


def _shape(bsdf: str) -> str:
    return f'<shape type="sphere">{bsdf}</shape>'


def test_a_roughconductor_is_a_rough_mirror_with_mitsubas_defaults(tmp_path):
    m = load(tmp_path, body=_shape('<bsdf type="roughconductor"/>')).objects[-1].material
    assert isinstance(m, MirrorMaterial) and not m.is_conductor  # material none: F = 1
    assert (m.alpha, m.distribution) == (0.1, "beckmann")
    m = load(tmp_path, body=_shape(
        '<bsdf type="roughconductor"><string name="material" value="Cu"/>'
        '<string name="distribution" value="ggx"/><float name="alpha_u" value="0.25"/>'
        '<float name="alpha_v" value="0.25"/><boolean name="sample_visible" value="false"/>'
        '</bsdf>')).objects[-1].material
    assert m.is_conductor and (m.alpha, m.distribution) == (0.25, "ggx")


def test_a_roughdielectric_is_frosted_glass(tmp_path):
    m = load(tmp_path, body=_shape(
        '<bsdf type="roughdielectric"><float name="alpha" value="0.3"/>'
        '<string name="int_ior" value="water"/><rgb name="specular_transmittance" '
        'value="0.9, 0.8, 0.7"/></bsdf>')).objects[-1].material
    assert isinstance(m, DielectricMaterial)
    assert (m.alpha, m.distribution, m.ior) == (0.3, "beckmann", 1.333)
    assert list(m.tint) == [0.9, 0.8, 0.7]


@pytest.mark.parametrize("bsdf, match", [
    ('<bsdf type="roughconductor"><float name="alpha_u" value="0.05"/><float name="alpha_v" '
     'value="0.3"/></bsdf>', r"s.xml:\d+: <bsdf type=\"roughconductor\">: alpha_u 0.05 and alpha_v "
     r"0.3: anisotropic roughness is not supported .*give one alpha, e.g. 0.122"),
    ('<bsdf type="roughdielectric"><texture type="checkerboard" name="alpha"/></bsdf>',
     r"s.xml:\d+: <texture type=\"checkerboard\" name=\"alpha\">: alpha given by a texture: .*"
     r"give alpha as <float"),
    ('<bsdf type="roughconductor"><float name="alpha" value="0.1"/><float name="alpha_u" '
     'value="0.1"/></bsdf>', r"alpha and alpha_u / alpha_v: give one roughness"),
    ('<bsdf type="roughconductor"><string name="distribution" value="phong"/></bsdf>',
     r"distribution: expected one of 'beckmann', 'ggx'; got 'phong'"),
    ('<bsdf type="roughdielectric"><float name="alpha" value="2"/></bsdf>',
     r"alpha: .*2.*the microfacet roughness"),
])
def test_what_blockhash_does_not_model_of_a_rough_bsdf_is_refused_by_name(tmp_path, bsdf, match):
    with pytest.raises(InputError, match=match):
        load(tmp_path, body=_shape(bsdf))


SCENE = """
[camera]
eye = [0.0, 1.0, 3.0]
target = [0.0, 0.0, 0.0]
fov_y_deg = 40.0
width = 16
height = 16
[materials.floor]
kind = "phong"
kd = 0.5
[materials.rough]
{material}
[[lights]]
kind = "point"
position = [0.0, 2.0, 0.0]
power = 10.0
[[objects]]
name = "floor"
material = "floor"
[objects.shape]
kind = "rectangle"
x = [-1.0, 1.0]
z = [-1.0, 1.0]
[[objects]]
name = "ball"
material = "rough"
[objects.shape]
kind = "sphere"
radius = 0.3
center = [0.0, 0.5, 0.0]
"""


def test_a_scene_files_mirror_and_glass_take_a_roughness():
    mirror = parse_scene(SCENE.format(material='kind = "mirror"\nreflectance = 0.9\n'
                                      'alpha = 0.2\ndistribution = "ggx"'))
    assert (mirror.objects[1].material.alpha, mirror.objects[1].material.distribution) == (0.2, "ggx")
    glass = parse_scene(SCENE.format(material='kind = "dielectric"\nior = 1.5\nalpha = 0.05'))
    assert (glass.objects[1].material.alpha, glass.objects[1].material.distribution) == (0.05, "beckmann")
    with pytest.raises(InputError, match=r"materials.rough.alpha: .*-0.1"):
        parse_scene(SCENE.format(material='kind = "mirror"\nreflectance = 0.9\nalpha = -0.1'))
    with pytest.raises(InputError, match=r"materials.rough.distribution: expected one of"):
        parse_scene(SCENE.format(material='kind = "dielectric"\nior = 1.5\ndistribution = "gxx"'))


# ----------------------------------------------------------------- plastic


def test_a_plastic_is_a_coated_receiver_with_mitsubas_defaults(tmp_path):
    from blockhash.scene.coat import coated_albedo

    m = load(tmp_path, body=_shape('<bsdf type="plastic"/>')).objects[-1].material
    air = 1.000277  # Mitsuba's default ext_ior: the coat's index is polypropylene's over air's
    assert m.coat == pytest.approx(1.49 / air) and m.one_sided  # front side only
    np.testing.assert_allclose(m.kd, coated_albedo(0.5, 1.49 / air))
    m = load(tmp_path, body=_shape(
        '<bsdf type="twosided"><bsdf type="plastic"><rgb name="diffuse_reflectance" '
        'value="0.9, 0.5, 0.1"/><string name="int_ior" value="pet"/><boolean name="nonlinear" '
        'value="true"/><float name="specular_reflectance" value="0.5"/><float name="ext_ior" '
        'value="1"/></bsdf></bsdf>')).objects[-1].material
    assert m.coat == 1.575 and not m.one_sided and list(m.coat_reflectance) == [0.5] * 3
    np.testing.assert_allclose(m.kd, coated_albedo([0.9, 0.5, 0.1], 1.575, nonlinear=True))


def test_a_roughplastic_is_a_rough_coat_with_mitsubas_defaults(tmp_path):
    from blockhash.scene.coat import coated_albedo

    m = load(tmp_path, body=_shape('<bsdf type="roughplastic"/>')).objects[-1].material
    eta = 1.49 / 1.000277
    assert (m.coat, m.alpha, m.distribution) == (pytest.approx(eta), 0.1, "beckmann")
    np.testing.assert_allclose(m.kd, coated_albedo(0.5, eta, alpha=0.1))
    # a rough coat lets less through than a smooth one, and reflects less back inside
    assert np.all(m.kd < coated_albedo(0.5, eta))
    m = load(tmp_path, body=_shape(
        '<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float '
        'name="alpha_u" value="0.3"/><float name="alpha_v" value="0.3"/><boolean '
        'name="nonlinear" value="true"/><float name="int_ior" value="1.9"/><boolean '
        'name="sample_visible" value="false"/></bsdf>')).objects[-1].material
    assert (m.coat, m.alpha, m.distribution) == (pytest.approx(1.9 / 1.000277), 0.3, "ggx")
    np.testing.assert_allclose(m.kd, coated_albedo(0.5, m.coat, True, 0.3, "ggx"))


def test_a_coats_roughness_needs_a_coat():
    from blockhash.scene.materials import PhongMaterial

    with pytest.raises(InputError, match=r"alpha: a roughness is the coat's"):
        PhongMaterial(kd=0.5, ks=0.0, n=0.0, alpha=0.1)


@pytest.mark.parametrize("bsdf, match", [
    ('<bsdf type="roughplastic"><float name="alpha_u" value="0.1"/><float name="alpha_v" '
     'value="0.3"/></bsdf>', r"anisotropic roughness is not supported"),
    ('<bsdf type="plastic"><texture type="checkerboard" name="diffuse_reflectance"/></bsdf>',
     r"a checkerboard under a plastic's coat is not supported"),
    ('<bsdf type="plastic"><float name="ext_ior" value="1.33"/></bsdf>',
     r"ext_ior 1.33: blockhash's plastics sit in air"),
])
def test_what_blockhash_does_not_model_of_a_plastic_is_refused_by_name(tmp_path, bsdf, match):
    with pytest.raises(InputError, match=match):
        load(tmp_path, body=_shape(bsdf))


def test_a_coat_checks_its_albedo():
    from blockhash.scene.coat import largest_albedo
    from blockhash.scene.materials import PhongMaterial

    top = largest_albedo(1.5)
    assert PhongMaterial(kd=top, ks=0.0, n=0.0, coat=1.5).coat == 1.5  # above 1: allowed
    with pytest.raises(InputError, match=r"kd = .* exceeds .* under this coat \(index 1.5\)"):
        PhongMaterial(kd=top * 1.01, ks=0.0, n=0.0, coat=1.5)
    with pytest.raises(InputError, match=r"coat: .*index of refraction"):
        PhongMaterial(kd=0.5, ks=0.0, n=0.0, coat=0.9)
    with pytest.raises(InputError, match=r"ks must be 0"):
        PhongMaterial(kd=0.5, ks=0.1, n=2.0, coat=1.5)


def test_rough_and_coated_materials_export_as_mitsubas_plugins(tmp_path):
    """Exported and read back, rough mirrors and glass and plastic, smooth and rough, are what
    they were."""
    import warnings
    from pathlib import Path

    from blockhash.scene.loader import load_scene
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    here = Path(__file__).resolve().parents[2] / "reference" / "mitsuba_xml"
    for name in ("rough.xml", "plastic.xml", "roughplastic.xml"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # rough.xml's max_depth, said on each load
            scene = load_scene(here / name)
            again = load_scene(export_mitsuba(scene, tmp_path / name))
        for a, b in zip(scene.objects, again.objects):
            assert type(a.material) is type(b.material), a.name
            assert getattr(a.material, "distribution", None) == getattr(b.material, "distribution", None)
            for field in ("alpha", "coat", "kd", "reflectance", "ior", "coat_reflectance"):
                if hasattr(a.material, field):
                    np.testing.assert_allclose(getattr(b.material, field),
                                               getattr(a.material, field), rtol=1e-6, err_msg=field)
