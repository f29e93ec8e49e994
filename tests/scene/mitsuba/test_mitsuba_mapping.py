"""Mitsuba 3 XML as its users write it: each construct is read as Mitsuba reads it (checked
against the installed mitsuba where there is one) or refused naming file:line, the element
and the way out."""

import math

import numpy as np
import pytest

from blockhash.errors import InputError
from blockhash.reference.mitsuba import mitsuba_available
from blockhash.scene.loader import load_scene
from blockhash.scene.mitsuba import sensor as mitsuba_sensor
from blockhash.scene.mitsuba.xml_values import FLAT_EMITTER_RGB, coordinate_system

needs_mitsuba = pytest.mark.skipif(not mitsuba_available()[0], reason=mitsuba_available()[1])
LIGHT = '<emitter type="point"><point name="position" x="0" y="2" z="0"/><rgb name="intensity" value="1"/></emitter>'
FLOOR = ('<shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="2"/>'
         '</transform><bsdf type="diffuse"/></shape>')
LOOKAT = '<lookat origin="0, 1, 3" target="0, 0, 0" up="0, 1, 0"/>'


def xml(*, to_world=LOOKAT, lens='<float name="fov" value="40"/>', sensor="", film="", light=LIGHT,
        body="", top="", scene='<scene version="3.0.0">'):
    """The scene text; line 2 the sensor, 4 its to_world, 5 ``sensor``, 6 the film, 8 the
    light, 10 ``body``."""
    return "\n".join([scene + top, '<sensor type="perspective">', lens,
                      f'<transform name="to_world">{to_world}</transform>', sensor,
                      '<film type="hdrfilm"><integer name="width" value="64"/>'
                      f'<integer name="height" value="32"/>{film}</film>',
                      "</sensor>", light, FLOOR, body, "</scene>"]) + "\n"


def load(tmp_path, text=None, **kw):
    p = tmp_path / "s.xml"
    p.write_text(text if text is not None else xml(**kw))
    return load_scene(p)


def mitsuba_scene(text):
    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, _ = load_mitsuba_module()
    return mi, mi.load_string(text)


# ----------------------------------------------------------------- mappings


@pytest.mark.parametrize("origin, target", [((0, 1, 3), (0, 0, 0)), ((1, 2, 3), (0, 0, 0)),
                                            ((0, 0.5, 0), (1, 0.5, 0)), ((0, 5, 0), (0, 0, 0.01))])
def test_a_lookat_without_up_takes_mitsubas_up(tmp_path, origin, target):
    o, t = ", ".join(map(str, origin)), ", ".join(map(str, target))
    scene = load(tmp_path, to_world=f'<lookat origin="{o}" target="{t}"/>')
    d = np.subtract(target, origin) / np.linalg.norm(np.subtract(target, origin))
    right, up, forward = scene.camera.basis()
    np.testing.assert_allclose(forward, d, atol=1e-12)
    s = coordinate_system(d)[0]
    np.testing.assert_allclose(up, (s - d * (s @ d)) / np.linalg.norm(s - d * (s @ d)), atol=1e-12)
    if origin == (0, 1, 3):  # read from Mitsuba 3.9.1: the sensor's y axis is +x here
        np.testing.assert_allclose(up, [1, 0, 0], atol=1e-12)


@needs_mitsuba
@pytest.mark.parametrize("to_world", [
    '<lookat origin="1, 2, 3" target="0, 0, 0"/>', '<lookat origin="0, 0.5, 0" target="1, 0.5, 0"/>',
    '<rotate x="1" angle="50"/><rotate y="1" angle="180"/><translate y="3" z="2.6"/>',
    '<lookat origin="0, 1, 3" target="0, 0, 0" up="1, 1, 0"/>'])
def test_the_camera_frame_is_mitsubas(tmp_path, to_world):
    text = xml(to_world=to_world)
    mi, loaded = mitsuba_scene(text)
    m = np.array(loaded.sensors()[0].world_transform().matrix, dtype=np.float64).reshape(4, 4)
    right, up, forward = load(tmp_path, text).camera.basis()
    np.testing.assert_allclose(np.stack([-right, up, forward], axis=1), m[:3, :3], atol=1e-5)


@pytest.mark.parametrize("lens, x_deg", [  # the horizontal fov Mitsuba 3.9.1 reports (x_fov)
    ('<float name="fov" value="40"/>', 40.0),
    ('<float name="fov" value="40"/><string name="fov_axis" value="y"/>', 72.10477),
    ('<float name="fov" value="40"/><string name="fov_axis" value="diagonal"/>', 36.06479),
    ('<float name="fov" value="40"/><string name="fov_axis" value="smaller"/>', 72.10477),
    ('<float name="fov" value="40"/><string name="fov_axis" value="larger"/>', 40.0),
    ('<string name="focal_length" value="50mm"/>', 42.31171),
    ('<string name="focal_length" value="35"/>', 57.87119),
    ("", 42.31171)])
def test_the_field_of_view_is_mitsubas(tmp_path, lens, x_deg):
    c = load(tmp_path, lens=lens).camera
    assert math.degrees(2 * math.atan(math.tan(math.radians(c.fov_y_deg) / 2) * 2)) == \
        pytest.approx(x_deg, abs=1e-4)


def test_an_emitter_spectrum_is_a_flat_spectrum_and_a_reflectance_one_grey(tmp_path):
    light = '<emitter type="point"><point name="position" value="0, 2, 0"/><spectrum name="intensity" value="6"/></emitter>'
    body = '<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="0.3"/></bsdf></shape>'
    scene = load(tmp_path, light=light, body=body)
    np.testing.assert_allclose(scene.lights[0].power / (4 * math.pi), [7.22876, 5.68975, 5.45350], rtol=1e-5)
    np.testing.assert_allclose(scene.objects[1].material.kd, 0.3)


SPECTRA = ["400:0.3, 500:0.5, 600:0.8, 700:0.2", "360:0.5, 830:0.5", "450:0.1, 550:0.9, 650:0.4",
           "380:0.9, 420:0.9, 430:0, 780:0", "300:0.4, 900:0.6", "550:0.7, 560:0.2"]


@needs_mitsuba
@pytest.mark.parametrize("spectrum", SPECTRA)
def test_a_spectrum_of_wavelength_pairs_is_mitsubas_colour(tmp_path, spectrum):
    """A reflectance (under D65, clipped to [0, 1]) and an emitter's intensity (an
    illuminant) as Mitsuba's RGB variants take the same spectrum, to float32 precision."""
    import warnings

    from blockhash.scene.mitsuba.sensor import MitsubaWarning

    mi, _ = mitsuba_scene('<scene version="3.0.0"/>')
    bsdf = mi.load_string(f'<bsdf version="3.0.0" type="diffuse"><spectrum name="reflectance" value="{spectrum}"/></bsdf>')
    emitter = mi.load_string(f'<emitter version="3.0.0" type="point"><spectrum name="intensity" value="{spectrum}"/></emitter>')
    light = f'<emitter type="point"><point name="position" value="0, 2, 0"/><spectrum name="intensity" value="{spectrum}"/></emitter>'
    body = f'<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="{spectrum}"/></bsdf></shape>'
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MitsubaWarning)
        scene = load(tmp_path, light=light, body=body)
    np.testing.assert_allclose(scene.objects[1].material.kd,
                               np.ravel(mi.traverse(bsdf)["reflectance.value"]), atol=2e-6)
    np.testing.assert_allclose(scene.lights[0].power / (4 * math.pi),
                               np.ravel(mi.traverse(emitter)["intensity.value"]), rtol=2e-6, atol=2e-6)


def test_a_spectrum_outside_srgb_is_clipped_as_mitsuba_with_a_warning(tmp_path):
    from blockhash.scene.mitsuba.sensor import MitsubaWarning

    body = '<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="400:1, 700:3"/></bsdf></shape>'
    with pytest.warns(MitsubaWarning, match=r"s.xml:10: .*400:1, 700:3.*outside \[0, 1\].*clipped to \[1.0, 1.0, 1.0\]"):
        scene = load(tmp_path, body=body)
    np.testing.assert_allclose(scene.objects[1].material.kd, 1.0)


@pytest.mark.parametrize("value, match", [("400:0.3, 300:0.5", "increasing wavelength"),
                                          ("400:0.3", "at least two"),
                                          ("400:0.3, 500:x", "wavelength:value pairs"),
                                          ("400:0.3:1, 500:2", "wavelength:value pairs"),
                                          ("400:nan, 500:0.5", "finite")])
def test_a_bad_spectrum_is_refused_by_line(tmp_path, value, match):
    body = f'<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="{value}"/></bsdf></shape>'
    with pytest.raises(InputError, match=r"s.xml:10: <spectrum name=\"reflectance\".*" + match):
        load(tmp_path, body=body)


@needs_mitsuba
def test_the_flat_emitter_colour_is_mitsubas():
    mi, _ = mitsuba_scene('<scene version="3.0.0"/>')
    np.testing.assert_allclose(np.array(mi.xyz_to_srgb(mi.Color3f(1, 1, 1))).ravel(), FLAT_EMITTER_RGB, rtol=1e-6)
    e = mi.load_string('<emitter version="3.0.0" type="point"><spectrum name="intensity" value="6"/></emitter>')
    np.testing.assert_allclose(np.array(mi.traverse(e)["intensity.value"]).ravel(), 6 * FLAT_EMITTER_RGB, rtol=1e-5)


@pytest.mark.parametrize("kind, n, spp", [("independent", 16, 16), ("stratified", 10, 16),
                                          ("stratified", 1000, 1024), ("ldsampler", 5, 16),
                                          ("orthogonal", 8, 9), ("multijitter", 36, 36),
                                          ("independent", 32, 32), ("independent", 128, 128),
                                          ("independent", 512, 512), ("multijitter", 10, 12)])
def test_sample_count_gives_the_samples_per_pixel(tmp_path, kind, n, spp):
    s = f'<sampler type="{kind}"><integer name="sample_count" value="{n}"/><integer name="seed" value="2"/></sampler>'
    assert load(tmp_path, sensor=s).camera.spp == spp
    assert load(tmp_path).camera.spp is None  # no sampler: blockhash's default


@needs_mitsuba
@pytest.mark.parametrize("kind", ["independent", "stratified", "orthogonal", "ldsampler", "multijitter"])
def test_each_samplers_rounding_is_mitsubas(kind):
    mi, _ = mitsuba_scene('<scene version="3.0.0"/>')
    for n in (1, 2, 4, 5, 9, 10, 16, 17, 36, 50, 64, 100, 1000):
        s = mi.load_dict({"type": kind, "sample_count": n})
        ours = mitsuba_sensor.sample_count(kind, n)
        assert ours == s.sample_count(), (kind, n)


@pytest.mark.parametrize("depth, body, bounces", [(None, "", 4), (-1, "", 4), (6, "", 4), (9, "", 7),
                                                  (10, "glass", 8), (13, "glass", 11)])
def test_max_depth_gives_the_photon_depth(tmp_path, depth, body, bounces):
    glass = ('<shape type="sphere"><float name="radius" value="0.2"/><bsdf type="dielectric"/></shape>'
             if body else "")
    top = f'<integrator type="path"><integer name="max_depth" value="{depth}"/></integrator>' if depth else ""
    assert load(tmp_path, top=top, body=glass).photons.max_bounces == bounces


def test_parameters_clip_planes_flip_normals_and_type_substitution(tmp_path):
    top = '<default name="kind" value="rectangle"/><default name="w" value="0.5"/>'
    body = '<shape type="$kind"><boolean name="flip_normals" value="true"/><bsdf type="diffuse"/></shape>'
    sensor = '<float name="near_clip" value="$w"/><float name="far_clip" value="6"/>'
    scene = load(tmp_path, top=top, body=body, sensor=sensor)
    np.testing.assert_allclose(scene.objects[1].mesh.vertex_normals, np.tile([0, 0, -1], (4, 1)))


def test_an_exported_files_settings_come_from_its_comment(tmp_path):
    from blockhash.scene.loader import load_scene as load_any
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    scene = load(tmp_path)
    out = export_mitsuba(scene, tmp_path / "e")
    assert load_any(out).camera.spp is None and load_any(out).photons.max_bounces == 4
    out.write_text(out.read_text().replace('value="$spp"', 'value="16"'))
    with pytest.raises(InputError, match=r"scene.xml:\d+: <integer name=\"sample_count\">: .*edited"):
        load_any(out)


# ----------------------------------------------------------------- refusals

SCALE = '<scale value="2"/>' + LOOKAT
CASES = [
    (dict(to_world='<scale x="-1"/>' + LOOKAT), r"s.xml:4: <transform name=\"to_world\">: a mirror flip.*mirror the rendered image"),
    (dict(to_world=SCALE), r"s.xml:4: <transform name=\"to_world\">: scale or shear.*Mitsuba refuses"),
    (dict(to_world='<matrix value="1 0.6 0 0  0 0.8 0 0  0 0 1 0  0 0 0 1"/>'), r"s.xml:4: .*scale or shear"),
    (dict(sensor='<float name="near_clip" value="4.2"/>'), r"s.xml:2: <sensor type=\"perspective\">: near_clip 4.2 may clip.*give near_clip <="),
    (dict(sensor='<float name="far_clip" value="3"/>'), r"s.xml:2: <sensor .*far_clip 3 clips the scene.*give far_clip >="),
    (dict(sensor='<float name="near_clip" value="0"/>'), r"s.xml:2: .*near_clip 0 must be > 0"),
    (dict(sensor='<float name="near_clip" value="5"/><float name="far_clip" value="4"/>'), r"s.xml:2: .*below far_clip"),
    (dict(light='<emitter type="point"><point name="position" value="0, 2, 0"/><transform name="to_world">'
                '<translate y="1"/></transform></emitter>'), r"s.xml:8: <emitter type=\"point\">: only one of position and to_world"),
    (dict(light='<emitter type="point"><spectrum name="intensity" filename="d65.spd"/></emitter>'),
     r"s.xml:8: <spectrum name=\"intensity\">: a spectrum read from a file.*<rgb"),
    (dict(top='<integrator type="pathh"/>'), r"s.xml:1: <integrator type=\"pathh\">: unsupported integrator; supported: path, ptracer"),
    (dict(top='<integrator type="path"><integer name="max_dept" value="3"/></integrator>'), r"s.xml:1: <integer name=\"max_dept\">: unsupported here.*max_depth"),
    (dict(top='<integrator type="path"><integer name="max_depth" value="1"/></integrator>'), r"s.xml:1: <integrator type=\"path\">: max_depth 1 renders only the emitters .*give max_depth -1 or >= 2"),
    (dict(top='<integrator type="path"><integer name="max_depth" value="-2"/></integrator>'), r"s.xml:1: .*max_depth -2"),
    (dict(top='<integrator type="path"><float name="max_depth" value="6"/></integrator>'), r"s.xml:1: .*max_depth must be given as integer"),
    (dict(sensor='<sampler type="independant"/>'), r"s.xml:5: <sampler type=\"independant\">: unsupported sampler; supported: independent"),
    (dict(sensor='<sampler type="independent"><integer name="sample_count" value="2000"/></sampler>'), r"s.xml:5: .*sample_count 2000: blockhash takes 1 to 1024 .*render more passes"),
    (dict(sensor='<sampler type="independent"><integer name="sample_count" value="0"/></sampler>'), r"s.xml:5: .*sample_count 0: blockhash takes 1 to 1024"),
    (dict(sensor='<sampler type="orthogonal"><integer name="sample_count" value="1000"/></sampler>'), r"s.xml:5: .*1000 \(orthogonal takes 1369\)"),
    (dict(sensor='<sampler type="stratified"><boolean name="jitter" value="false"/></sampler>'), r"s.xml:5: .*jitter = false"),
    (dict(film='<rfilter type="lanczos"/>'), r"s.xml:6: <rfilter type=\"lanczos\">: unsupported reconstruction filter; supported: box, tent, gaussian"),
    (dict(film='<rfilter type="gausian"/>'), r"s.xml:6: <rfilter type=\"gausian\">: unsupported reconstruction filter"),
    (dict(film='<rfilter type="box"><float name="radius" value="1"/></rfilter>'), r"s.xml:6: <rfilter type=\"box\">: a box filter of radius 1: .*tent or gaussian"),
    (dict(film='<rfilter type="tent"><float name="radius" value="0.2"/></rfilter>'), r"s.xml:6: .*radius.*above 0.5"),
    (dict(film='<rfilter type="gaussian"><float name="radius" value="1"/></rfilter>'), r"s.xml:6: <float name=\"radius\">: unsupported here.*stddev"),
    (dict(film='<integer name="crop_width" value="80"/>'), r"s.xml:6: <film type=\"hdrfilm\">: the crop window at \(0, 0\) of 80 x 32 pixels does not lie inside the 64 x 32 film"),
    (dict(film='<string name="pixel_format" value="luminance"/>'), r"s.xml:6: .*pixel_format 'luminance'"),
    (dict(scene="<scene>"), r"s.xml:1: <scene>: missing version attribute.*version=\"3.0.0\""),
    (dict(scene='<scene version="0.6.0">'), r"s.xml:1: <scene>: version 0.6.0: a file for Mitsuba 0.x"),
    (dict(to_world='<lookat origin="0, $h, 3" target="0, 0, 0"/>'), r"s.xml:4: <lookat>: undefined parameter \$h.*<default name=\"h\""),
    (dict(body='<shape type="$kind"/>'), r"s.xml:10: <shape type=\"\$kind\">: undefined parameter \$kind"),
    (dict(body='<shape type="sphere"><float name="radius" value="0"/><bsdf type="diffuse"/></shape>'), r"s.xml:10: <shape type=\"sphere\">: radius 0"),
    (dict(lens='<float name="fov" value="180"/>'), r"s.xml:2: <sensor .*horizontal field of view of 180 degrees"),
    (dict(lens='<float name="fov" value="40"/><string name="focal_length" value="50mm"/>'), r"s.xml:2: .*either fov or focal_length"),
    (dict(lens='<float name="fov" value="40"/><string name="fov_axis" value="z"/>'), r"s.xml:2: .*fov_axis 'z'"),
    (dict(light=""), r"s.xml:1: <scene>: no <emitter>.*point, spot, directional and area.*inside a shape"),
    (dict(light='<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>'),
     r"s.xml:8: <emitter type=\"envmap\">: environment map not found: 'sky.exr', looked for at .*"
     r"fix the name or add <path"),
    (dict(light='<emitter type="constant"><float name="scale" value="2"/></emitter>'), r"s.xml:8: <float name=\"scale\">: unsupported here"),
    (dict(light='<emitter type="area"/>'), r"s.xml:8: <emitter type=\"area\">: an area emitter belongs inside a <shape>.*move it into one"),
    (dict(body='<shape type="sphere"><bsdf type="conductor"><string name="material" value="none"/></bsdf>'
               '<emitter type="area"/></shape>'), r"s.xml:10: <emitter type=\"area\">: an area emitter on a mirror \(conductor\) shape.*diffuse BSDF"),
    (dict(body='<shape type="sphere"><bsdf type="dielectric"/><emitter type="area"/></shape>'),
     r"s.xml:10: <emitter type=\"area\">: an area emitter on a glass"),
    (dict(body='<shape type="rectangle"><emitter type="area"><texture type="checkerboard" name="radiance">'
               '</texture></emitter></shape>'),
     r"s.xml:10: <texture type=\"checkerboard\" name=\"radiance\">: a checkerboard texture on a light is not "
     r"supported; supported: bitmap"),
    (dict(body='<shape type="sphere"><emitter type="area"><texture type="bitmap" name="radiance">'
               '<string name="filename" value="a.png"/></texture></emitter></shape>'),
     r"s.xml:10: <texture type=\"bitmap\" name=\"radiance\">: texture image not found: 'a.png'"),
    (dict(body='<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="-1, 1, 1"/></emitter></shape>'),
     r"s.xml:10: <emitter type=\"area\">: .*emission\[0\]: expected a number in \[0, inf\); got -1"),
    (dict(body='<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="0"/></emitter></shape>'),
     r"s.xml:10: <emitter type=\"area\">: .*emits nothing"),
    (dict(body='<shape type="rectangle"><transform name="to_world"><scale x="0"/></transform><emitter type="area"/></shape>'),
     r"s.xml:10: <shape type=\"rectangle\">: the to_world transform is singular"),
    (dict(body='<shape type="rectangle"><emitter type="point"/></shape>'), r"s.xml:10: <emitter type=\"point\">: a 'point' emitter inside a shape"),
    (dict(light='<emitter type="directional"><vector name="direction" x="0" y="0" z="0"/></emitter>'),
     r"s.xml:8: <emitter type=\"directional\">: .*direction: expected a non-zero direction"),
    (dict(light='<emitter type="directional"><vector name="direction" x="0" y="-1" z="0"/>'
                '<transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>'),
     r"s.xml:8: <emitter type=\"directional\">: only one of direction and to_world"),
    (dict(light='<emitter type="directional"><rgb name="irradiance" value="nan, 1, 1"/></emitter>'),
     r"s.xml:8: .*(finite|nan)"),
    (dict(body='<shape type="cube"><default name="x" value="1"/></shape>'), r"s.xml:10: <default name=\"x\">: a <default> must sit directly in <scene>"),
]


@pytest.mark.parametrize("kw, match", CASES, ids=[m.split(": ", 2)[-1][:40] for _, m in CASES])
def test_what_blockhash_cannot_do_as_mitsuba_does_is_refused_by_line(tmp_path, kw, match):
    with pytest.raises(InputError, match=match):
        load(tmp_path, **kw)


def test_a_scene_with_no_shape_is_refused(tmp_path):
    text = xml().replace(FLOOR, "")
    with pytest.raises(InputError, match=r"s.xml:1: <scene>: no <shape>"):
        load(tmp_path, text)


#: The refusals above that are Mitsuba's own (it refuses the same text).
MITSUBAS = ("scale or shear", "must be > 0", "below far_clip", "only one of position", "pathh",
            "max_dept\\\"", "max_depth -2", "must be given as integer", "independant", "gausian",
            "missing version", "undefined parameter", "180 degrees", "either fov")


@needs_mitsuba
@pytest.mark.parametrize("kw, match", [c for c in CASES if any(k in c[1] for k in MITSUBAS)],
                         ids=lambda v: str(v)[:40])
def test_mitsuba_refuses_these_too(kw, match):
    mi, _ = mitsuba_scene('<scene version="3.0.0"/>')
    with pytest.raises(Exception):
        mi.load_string(xml(**kw))


@needs_mitsuba
def test_mitsuba_renders_the_flip_that_blockhash_refuses():
    mi, loaded = mitsuba_scene(xml(to_world=CASES[0][0]["to_world"]))
    assert np.linalg.det(np.array(loaded.sensors()[0].world_transform().matrix).reshape(4, 4)[:3, :3]) < 0


def test_the_camera_depth_max_depth_is_checked_against_is_the_renderers():
    from blockhash.frame.shading import MAX_DIELECTRIC_EVENTS, MAX_MIRROR_BOUNCES
    from blockhash.scene.model import DIELECTRIC_MAX_BOUNCES, MAX_BOUNCES

    assert (MAX_MIRROR_BOUNCES, MAX_DIELECTRIC_EVENTS) == (MAX_BOUNCES, DIELECTRIC_MAX_BOUNCES)


def test_an_area_emitter_inside_a_shape_and_a_directional_emitter_are_read(tmp_path):
    """A rectangle holding <emitter type="area"> (no BSDF: Mitsuba's default for an emitting
    shape, a black diffuse) is an object and an AreaLight of its radiance, emitting along the rectangle's +z turned by
    to_world; a directional emitter's to_world turns its +z into the direction."""
    from blockhash.scene.model import AreaLight, DirectionalLight, PhongMaterial

    body = ('<shape type="rectangle" id="lamp"><transform name="to_world"><scale value="0.25"/>'
            '<rotate x="1" angle="90"/><translate y="2"/></transform>'
            '<emitter type="area"><rgb name="radiance" value="10, 8, 6"/></emitter></shape>')
    light = ('<emitter type="directional"><transform name="to_world"><lookat origin="0, 0, 0" '
             'target="0.6, -0.8, 0"/></transform><rgb name="irradiance" value="3"/></emitter>')
    scene = load(tmp_path, body=body, light=light)
    sun, lamp = scene.lights
    assert isinstance(sun, DirectionalLight) and isinstance(lamp, AreaLight)
    np.testing.assert_allclose(sun.direction, [0.6, -0.8, 0.0], atol=1e-12)
    np.testing.assert_allclose(sun.irradiance, 3.0)
    obj = next(o for o in scene.objects if o.name == "lamp")
    assert lamp.object == "lamp" and lamp.mesh is obj.mesh
    assert isinstance(obj.material, PhongMaterial) and obj.material.one_sided
    np.testing.assert_allclose(obj.material.kd, 0.0)  # 0.5 on a shape that does not emit
    np.testing.assert_allclose(lamp.radiance, [10.0, 8.0, 6.0])
    assert lamp.area == pytest.approx(0.25, rel=1e-12)  # (2 x 0.25)^2
    np.testing.assert_allclose(lamp.face_normals, np.tile([0.0, -1.0, 0.0], (2, 1)), atol=1e-12)
    np.testing.assert_allclose(lamp.power, np.pi * 0.25 * np.array([10.0, 8.0, 6.0]))


@needs_mitsuba
def test_mitsuba_reads_the_same_area_light_power(tmp_path):
    """Mitsuba's own scene of the same file: its area emitter's shape has the area blockhash
    reads (the power, pi L A, follows)."""
    body = ('<shape type="rectangle" id="lamp"><transform name="to_world"><scale value="0.25"/>'
            '<rotate x="1" angle="90"/><translate y="2"/></transform>'
            '<emitter type="area"><rgb name="radiance" value="10"/></emitter></shape>')
    text = xml(body=body)
    scene = load(tmp_path, text=text)
    mi, loaded = mitsuba_scene(text)
    areas = [float(s.surface_area()[0]) for s in loaded.shapes() if s.is_emitter()]
    assert areas == [pytest.approx(scene.lights[1].area, rel=1e-6)]


# ----------------------------------------------------------------- published files' elements

def test_path_elements_are_searched_for_the_files_a_scene_names(tmp_path):
    import trimesh

    (tmp_path / "meshes").mkdir()
    (tmp_path / "other").mkdir()
    trimesh.creation.box().export(tmp_path / "meshes" / "box.ply")
    body = '<shape type="ply"><string name="filename" value="box.ply"/><bsdf type="diffuse"/></shape>'
    scene = load(tmp_path, top='<path value="other"/><path value="meshes"/>', body=body)
    assert len(scene.objects) == 2
    with pytest.raises(InputError, match=r"s.xml:10: <shape type=\"ply\">: mesh file not found: "
                                         r"'box.ply', looked for at .*other.*s?.*add <path value"):
        load(tmp_path, top='<path value="other"/>', body=body)
    with pytest.raises(InputError, match=r"s.xml:1: <path>: folder not found: 'nowhere', looked for at .*nowhere"):
        load(tmp_path, top='<path value="nowhere"/>')


def test_a_path_in_an_included_file_is_resolved_as_mitsuba_resolves_it(tmp_path):
    """Mitsuba resolves a relative <path> through its file resolver, whose first folder is the
    top file's: ``include/parts.xml``'s ``../meshes`` is found beside the top file's folder,
    as Mitsuba's documentation scenes name their meshes."""
    import trimesh

    (tmp_path / "scenes" / "include").mkdir(parents=True)
    (tmp_path / "meshes").mkdir()
    trimesh.creation.box().export(tmp_path / "meshes" / "box.ply")
    (tmp_path / "scenes" / "include" / "parts.xml").write_text(
        '<scene version="3.0.0">\n<path value="../meshes"/>\n<shape type="ply">'
        '<string name="filename" value="box.ply"/></shape>\n</scene>\n')
    top = tmp_path / "scenes" / "s.xml"
    top.write_text(xml(body='<include filename="include/parts.xml"/>'))
    assert len(load_scene(top).objects) == 2


def test_a_reference_may_name_what_the_file_defines_after_it(tmp_path):
    """Mitsuba resolves <ref id> after reading the whole file: a shape may name a BSDF and an
    area emitter defined below it."""
    body = ('<shape type="rectangle"><ref id="later"/><ref id="lamp"/></shape>'
            '<bsdf type="diffuse" id="later"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf>'
            '<emitter type="area" id="lamp"><rgb name="radiance" value="3"/></emitter>')
    scene = load(tmp_path, body=body)
    lamp = scene.objects[-1]
    np.testing.assert_allclose(lamp.material.kd, [0.2, 0.4, 0.6])
    assert len(scene.lights) == 2


def test_an_include_is_read_in_place_and_its_errors_name_its_own_file(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "ball.xml").write_text(
        '<scene version="3.0.0">\n<shape type="sphere"><float name="radius" value="0.3"/>\n'
        '<bsdf type="conductor"/></shape>\n</scene>\n')
    scene = load(tmp_path, body='<include filename="parts/ball.xml"/>')
    assert len(scene.objects) == 2 and scene.specular_objects
    (tmp_path / "parts" / "bad.xml").write_text(
        '<scene version="3.0.0">\n\n<shape type="sphere"><float name="radius" value="0"/></shape>\n</scene>\n')
    with pytest.raises(InputError, match=r"bad.xml:3: <shape type=\"sphere\">: radius 0"):
        load(tmp_path, body='<include filename="parts/bad.xml"/>')
    with pytest.raises(InputError, match=r"s.xml:10: <include>: included file not found: 'gone.xml'"):
        load(tmp_path, body='<include filename="gone.xml"/>')


def test_an_include_that_includes_itself_is_an_error_naming_the_chain(tmp_path):
    (tmp_path / "a.xml").write_text('<scene version="3.0.0"><include filename="b.xml"/></scene>')
    (tmp_path / "b.xml").write_text('<scene version="3.0.0">\n<include filename="a.xml"/></scene>')
    with pytest.raises(InputError, match=r"b.xml:2: <include>: an include cycle: .*s.xml -> .*a.xml "
                                         r"-> .*b.xml -> .*a.xml; remove one"):
        load(tmp_path, body='<include filename="a.xml"/>')


@pytest.mark.parametrize("ior, value", [('"water"', 1.333), ('"diamond"', 2.419), ('"bk7"', 1.5046),
                                        ("1.7", 1.7)])
def test_named_indices_of_refraction_are_mitsubas(tmp_path, ior, value):
    kind = "string" if ior.startswith('"') else "float"
    body = (f'<shape type="sphere"><bsdf type="dielectric"><{kind} name="int_ior" value={ior if kind == "string" else chr(34) + ior + chr(34)}/>'
            '<string name="ext_ior" value="air"/></bsdf></shape>')
    scene = load(tmp_path, body=body)
    assert scene.objects[-1].material.ior == pytest.approx(value)


def test_an_unknown_named_ior_is_refused_with_the_names(tmp_path):
    body = '<shape type="sphere"><bsdf type="dielectric"><string name="int_ior" value="glas"/></bsdf></shape>'
    with pytest.raises(InputError, match=r"int_ior 'glas' is not one of Mitsuba's .*water.*give the index"):
        load(tmp_path, body=body)


@needs_mitsuba
def test_the_named_indices_are_those_mitsuba_reads():
    from blockhash.scene.mitsuba.bsdfs import IORS

    mi, _ = mitsuba_scene('<scene version="3.0.0"/>')
    for name, value in IORS.items():
        bsdf = mi.load_dict({"type": "dielectric", "int_ior": name, "ext_ior": "vacuum"})
        assert mi.traverse(bsdf)["eta"] == pytest.approx(value, abs=1e-6), name


def test_a_conductor_with_its_defaults_is_mitsubas_perfect_mirror(tmp_path):
    from blockhash.scene.model import MirrorMaterial

    scene = load(tmp_path, body='<shape type="sphere"><bsdf type="conductor"/></shape>')
    material = scene.objects[-1].material
    assert isinstance(material, MirrorMaterial) and (material.reflectance == 1.0).all()


@needs_mitsuba
@pytest.mark.parametrize("bsdf", [
    '<string name="material" value="Au"/>', '<string name="material" value="Cu_palik"/>',
    '<string name="material" value="AlSb"/><rgb name="specular_reflectance" value="0.9, 0.8, 0.7"/>',
    '<rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 1.6"/>',
    '<float name="eta" value="1.5"/>', '<float name="k" value="2"/>',
    '<spectrum name="eta" value="400:1.5, 700:0.2"/><spectrum name="k" value="400:3, 700:4"/>'])
def test_a_conductors_eta_and_k_are_mitsubas(tmp_path, bsdf):
    """A conductor's preset, its eta and k (numbers, colours, spectra: eta and k are not
    clipped at 1) and its defaults (eta 0, k 1) read as Mitsuba reads them."""
    mi, _ = mitsuba_scene('<scene version="3.0.0"/>')
    theirs = mi.traverse(mi.load_string(f'<bsdf version="3.0.0" type="conductor">{bsdf}</bsdf>'))
    material = load(tmp_path, body=f'<shape type="sphere"><bsdf type="conductor">{bsdf}</bsdf></shape>').objects[-1].material
    assert material.is_conductor
    for name in ("eta", "k"):
        np.testing.assert_allclose(getattr(material, name),
                                   np.broadcast_to(np.ravel(theirs[f"{name}.value"]), (3,)), atol=2e-6)
    np.testing.assert_allclose(material.reflectance,
                               np.broadcast_to(np.ravel(theirs["specular_reflectance.value"]), (3,)), atol=2e-6)


def test_focus_distance_on_a_pinhole_changes_nothing(tmp_path):
    plain = load(tmp_path)
    focused = load(tmp_path, lens='<float name="fov" value="40"/><float name="focus_distance" value="3.5"/>')
    for field in ("eye", "target", "up", "fov_y_deg", "width", "height"):
        assert np.array_equal(getattr(focused.camera, field), getattr(plain.camera, field)), field


@pytest.mark.parametrize("wrapper", ["moment", "stokes"])
def test_moment_and_stokes_render_the_integrator_inside_with_one_warning(tmp_path, wrapper):
    top = (f'<integrator type="{wrapper}"><integrator type="path">'
           '<integer name="max_depth" value="12"/></integrator></integrator>')
    with pytest.warns(mitsuba_sensor.MitsubaWarning, match=rf"s.xml:1: <integrator type=\"{wrapper}\">: "
                      r".*blockhash renders the integrator inside") as caught:
        scene = load(tmp_path, top=top)
    assert len(caught) == 1
    assert scene.photons.max_bounces == 10  # the inner path's max_depth 12, followed


SHAPES_BODY = {
    "disk": '<shape type="disk"><transform name="to_world"><scale value="0.4"/><rotate x="1" angle="-90"/>'
            '<translate y="0.5"/></transform></shape>',
    "cylinder": '<shape type="cylinder"><point name="p0" x="0" y="0" z="0"/><point name="p1" x="0" y="0.8" z="0"/>'
                '<float name="radius" value="0.3"/></shape>',
}


@pytest.mark.parametrize("kind", sorted(SHAPES_BODY))
def test_disk_and_cylinder_have_mitsubas_area_and_facing(tmp_path, kind):
    scene = load(tmp_path, body=SHAPES_BODY[kind])
    mesh = scene.objects[-1].mesh
    want = {"disk": math.pi * 0.4 ** 2, "cylinder": 2 * math.pi * 0.3 * 0.8}[kind]
    assert mesh.area == pytest.approx(want, rel=1e-9)
    if kind == "disk":  # facing +z turned to +y
        np.testing.assert_allclose(mesh.face_normals, np.tile([0, 1.0, 0], (len(mesh.faces), 1)), atol=1e-12)
    else:  # outward, the open tube's
        radial = mesh.triangles_center * [1, 0, 1]
        assert (np.sum(mesh.face_normals * radial, axis=1) > 0).all()
        assert mesh.bounds[:, 1].tolist() == pytest.approx([0.0, 0.8])


@needs_mitsuba
@pytest.mark.parametrize("kind", sorted(SHAPES_BODY))
def test_mitsuba_reads_the_same_disk_and_cylinder(kind):
    mi, loaded = mitsuba_scene(xml(body=SHAPES_BODY[kind].replace(f'type="{kind}"', f'type="{kind}" id="it"', 1)))
    [shape] = [s for s in loaded.shapes() if s.id() == "it"]
    want = {"disk": math.pi * 0.4 ** 2, "cylinder": 2 * math.pi * 0.3 * 0.8}[kind]
    assert float(np.ravel(shape.surface_area())[0]) == pytest.approx(want, rel=1e-5)


def test_a_cylinder_without_length_is_refused(tmp_path):
    body = '<shape type="cylinder"><point name="p1" x="0" y="0" z="0"/></shape>'
    with pytest.raises(InputError, match=r"s.xml:10: <shape type=\"cylinder\">: p0 = p1 .*no length"):
        load(tmp_path, body=body)


GROUP = ('<shape type="shapegroup" id="pair"><shape type="sphere"><float name="radius" value="0.1"/>'
         '<bsdf type="conductor"/></shape><shape type="cube"><transform name="to_world"><scale value="0.1"/>'
         '<translate x="0.3"/></transform></shape></shape>'
         '<shape type="instance" id="left"><ref id="pair"/><transform name="to_world"><translate x="-0.5" y="0.2"/></transform></shape>'
         '<shape type="instance" id="right"><ref id="pair"/><transform name="to_world"><translate x="0.5" y="0.2"/></transform></shape>')


def test_instances_of_a_shapegroup_place_its_shapes(tmp_path):
    from blockhash.scene.model import MirrorMaterial

    scene = load(tmp_path, body=GROUP)
    names = [o.name for o in scene.objects]
    assert names[1:] == ["left/sphere-0", "left/cube-1", "right/sphere-0", "right/cube-1"]
    by = {o.name: o for o in scene.objects}
    np.testing.assert_allclose(by["right/cube-1"].mesh.bounds.mean(axis=0), [0.8, 0.2, 0.0], atol=1e-12)
    np.testing.assert_allclose(by["left/sphere-0"].mesh.bounds.mean(axis=0), [-0.5, 0.2, 0.0], atol=1e-3)
    assert isinstance(by["left/sphere-0"].material, MirrorMaterial)
    with pytest.raises(InputError, match=r"s.xml:10: <ref>: no shapegroup with id 'pairs'"):
        load(tmp_path, body=GROUP.replace('<ref id="pair"/><transform name="to_world"><translate x="0.5"',
                                          '<ref id="pairs"/><transform name="to_world"><translate x="0.5"'))


@needs_mitsuba
def test_mitsuba_places_the_instances_where_blockhash_does(tmp_path):
    mi, loaded = mitsuba_scene(xml(body=GROUP))
    scene = load(tmp_path, body=GROUP)
    for name in ("left", "right"):
        [inst] = [s for s in loaded.shapes() if s.id() == name]
        box = inst.bbox()
        ours = np.vstack([o.mesh.bounds for o in scene.objects if o.name.startswith(name + "/")])
        np.testing.assert_allclose([list(box.min), list(box.max)], [ours.min(axis=0), ours.max(axis=0)],
                                   atol=2e-3)  # the icosphere's tessellation


def test_a_top_level_area_emitter_referred_to_by_a_shape_is_its_light(tmp_path):
    inline = load(tmp_path, body='<shape type="disk"><emitter type="area"><rgb name="radiance" value="2"/>'
                                 '</emitter><transform name="to_world"><translate y="1"/></transform></shape>')
    by_ref = load(tmp_path, top='<emitter type="area" id="lamp"><rgb name="radiance" value="2"/></emitter>',
                  body='<shape type="disk"><ref id="lamp"/><transform name="to_world"><translate y="1"/>'
                       '</transform></shape>')
    a, b = inline.lights[-1], by_ref.lights[-1]
    np.testing.assert_allclose(a.power, b.power)
    with pytest.raises(InputError, match=r"s.xml:1: <emitter type=\"area\">: an area emitter no shape refers to"):
        load(tmp_path, top='<emitter type="area" id="lamp"/>')


def write_serialized(path, meshes, *, version=4, double=False, normals=False):
    """A .serialized file of ``meshes`` [(vertices, faces)] as Mitsuba's format documents it."""
    import struct
    import zlib

    out, offsets = bytearray(), []
    real = "<f8" if double else "<f4"
    for i, (v, f) in enumerate(meshes):
        offsets.append(len(out))
        flags = (0x2000 if double else 0x1000) | (0x0001 if normals else 0)
        body = struct.pack("<I", flags) + (f"mesh{i}".encode() + b"\0" if version == 4 else b"")
        body += struct.pack("<QQ", len(v), len(f)) + np.asarray(v, real).tobytes()
        if normals:
            n = np.asarray(v, np.float64) / np.linalg.norm(v, axis=1, keepdims=True)
            body += n.astype(real).tobytes()
        body += np.asarray(f, "<u4").tobytes()
        out += struct.pack("<HH", 0x041C, version) + zlib.compress(body)
    out += np.asarray(offsets, "<u8" if version == 4 else "<u4").tobytes() + struct.pack("<I", len(meshes))
    path.write_bytes(bytes(out))


TETRA = (np.array([[1.0, 1, 1], [-1, -1, 1], [-1, 1, -1], [1, -1, -1]]) * 0.2,
         np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]]))
BOX = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]) * 0.3 + [0.1, 0.2, 0.3],
       np.array([[0, 1, 2], [0, 2, 3]]))


@pytest.mark.parametrize("version, double, normals", [(4, False, False), (4, True, True), (3, False, True)])
def test_a_serialized_files_meshes_are_read_by_shape_index(tmp_path, version, double, normals):
    write_serialized(tmp_path / "m.serialized", [TETRA, BOX], version=version, double=double, normals=normals)
    for index, (v, f) in enumerate([TETRA, BOX]):
        body = (f'<shape type="serialized"><string name="filename" value="m.serialized"/>'
                f'<integer name="shape_index" value="{index}"/></shape>')
        mesh = load(tmp_path, body=body).objects[-1].mesh
        np.testing.assert_allclose(mesh.vertices, v, atol=1e-7)
        assert mesh.faces.tolist() == f.tolist()
        if normals:
            np.testing.assert_allclose(mesh.vertex_normals, v / np.linalg.norm(v, axis=1, keepdims=True), atol=1e-6)


def test_bad_serialized_files_are_refused_naming_the_file(tmp_path):
    write_serialized(tmp_path / "m.serialized", [TETRA])
    body = '<shape type="serialized"><string name="filename" value="m.serialized"/><integer name="shape_index" value="3"/></shape>'
    with pytest.raises(InputError, match=r"s.xml:10: .*m.serialized: shape_index 3 is outside the file's 1 mesh"):
        load(tmp_path, body=body)
    (tmp_path / "m.serialized").write_bytes(b"\x1c\x05\x04\x00" + b"\0" * 8)
    with pytest.raises(InputError, match=r"identifier is 0x051C, not 0x041C"):
        load(tmp_path, body=body.replace("3", "0"))


@needs_mitsuba
def test_mitsuba_reads_the_same_serialized_meshes(tmp_path):
    write_serialized(tmp_path / "m.serialized", [TETRA, BOX], double=True)
    for index, (v, _) in enumerate([TETRA, BOX]):
        mi, _ = mitsuba_scene('<scene version="3.0.0"/>')
        mesh = mi.load_dict({"type": "serialized", "filename": str(tmp_path / "m.serialized"),
                             "shape_index": index})
        np.testing.assert_allclose(np.array(mi.traverse(mesh)["vertex_positions"]).reshape(-1, 3), v, atol=1e-6)


DIRECT = '<integrator type="direct"><integer name="emitter_samples" value="2"/></integrator>'


def test_the_direct_integrator_asks_for_direct_light_only_with_one_warning(tmp_path):
    with pytest.warns(mitsuba_sensor.MitsubaWarning, match=r"s.xml:1: <integrator type=\"direct\">: "
                      r"blockhash renders the direct light alone.*nothing seen in mirrors") as caught:
        scene = load(tmp_path, top=DIRECT)
    assert len(caught) == 1 and scene.photons.direct_only
    assert not load(tmp_path).photons.direct_only


@pytest.mark.gl
def test_a_direct_only_scene_renders_its_direct_layer_alone(tmp_path):
    import warnings

    import blockhash
    from blockhash import RenderPlan

    body = '<shape type="sphere"><float name="radius" value="0.3"/><bsdf type="conductor"/></shape>'
    with pytest.warns(mitsuba_sensor.MitsubaWarning):
        direct = load(tmp_path, top=DIRECT, body=body).with_size(24, 12)
    full = load(tmp_path, body=body).with_size(24, 12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning that the caustic is missing: none was asked
        only = blockhash.render(direct, photons=4_000, plan=RenderPlan(passes=2))
    both = blockhash.render(full, photons=4_000, plan=RenderPlan(passes=2))
    assert only.info["photons_emitted"] == 0 and (only.caustic == 0).all() and only.indirect is None
    assert both.caustic.max() > 0
    same = (only.direct == both.direct).all(axis=2)
    # the same direct light, less where a pixel's samples meet the mirror ball (black now)
    assert (only.direct <= both.direct * (1 + 1e-6) + 1e-12).all()
    assert 0 < (~same).sum() < same.size / 4


@needs_mitsuba
@pytest.mark.gl
def test_the_direct_only_render_is_mitsubas_direct_integrator_on_diffuse_surfaces(tmp_path):
    import blockhash
    from blockhash import RenderPlan

    # (Mitsuba 3.9's direct integrator counts a point light once per emitter sample: with
    # emitter_samples = 2 its image is twice as bright; the default, 1, is compared)
    text = xml(top='<integrator type="direct"/>', film="<rfilter type=\"box\"/>")
    with pytest.warns(mitsuba_sensor.MitsubaWarning):
        scene = load(tmp_path, text)
    ours = blockhash.render(scene, photons=4_000, spp=16, plan=RenderPlan(passes=1)).direct.astype(np.float64)
    mi, loaded = mitsuba_scene(text)
    theirs = np.asarray(mi.render(loaded, spp=256, seed=1), np.float64)[..., :3]
    assert abs(ours.sum() - theirs.sum()) / theirs.sum() < 0.01


@pytest.mark.parametrize("depth, glass, photons, camera", [(3, False, 1, 1), (5, False, 3, 3), (9, True, 7, 7),
                                                           (6, False, 4, None)])
def test_a_small_max_depth_is_followed_by_photons_and_camera_rays_with_one_warning(tmp_path, depth, glass,
                                                                                  photons, camera):
    import warnings

    body = '<shape type="sphere"><float name="radius" value="0.2"/><bsdf type="dielectric"/></shape>' if glass else ""
    top = f'<integrator type="path"><integer name="max_depth" value="{depth}"/></integrator>'
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load(tmp_path, top=top, body=body)
    assert (scene.photons.max_bounces, scene.photons.camera_bounces) == (photons, camera)
    said = [str(w.message) for w in caught if w.category is mitsuba_sensor.MitsubaWarning]
    if camera is None:
        assert not said
    else:
        assert len(said) == 1 and f"max_depth {depth}: blockhash follows at most {depth - 2}" in said[0]


def test_max_depth_2_is_direct_light_alone(tmp_path):
    top = '<integrator type="path"><integer name="max_depth" value="2"/></integrator>'
    with pytest.warns(mitsuba_sensor.MitsubaWarning, match="max_depth 2: blockhash renders the direct light alone"):
        scene = load(tmp_path, top=top)
    assert scene.photons.direct_only and scene.photons.camera_bounces == 0


def test_a_parameter_is_given_as_mitsubas_dash_d_gives_it(tmp_path):
    """Mitsuba's documentation scenes leave $spp to the command line (mitsuba -D spp=16): the
    loader's defines give it, over a <default> too; a TOML scene takes none."""
    from blockhash.cli import main

    sampler = '<sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>'
    path = tmp_path / "s.xml"
    path.write_text(xml(sensor=sampler))
    with pytest.raises(InputError, match=r"undefined parameter \$spp .*-D spp=VALUE"):
        load_scene(path)
    assert load_scene(path, {"spp": "16"}).camera.spp == 16
    path.write_text(xml(top='<default name="spp" value="4"/>', sensor=sampler))
    assert load_scene(path).camera.spp == 4
    assert load_scene(path, {"spp": 9}).camera.spp == 9
    with pytest.raises(InputError, match=r"parameter name 'a b'"):
        load_scene(path, {"a b": 1})
    toml = tmp_path / "s.toml"
    toml.write_text("")
    with pytest.raises(InputError, match=r"a TOML scene has none"):
        load_scene(toml, {"spp": 4})
    with pytest.raises(SystemExit):
        main(["render", str(path), "-D", "spp"])


def test_a_twosided_of_two_diffuse_bsdfs_is_two_one_sided_sheets(tmp_path):
    """The front BSDF on the faces' front, the back one on a copy turned inside out just
    behind it; a twosided of two other BSDFs is refused by line."""
    two = ('<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.1, 0.1"/>'
           '</bsdf><bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.1, 0.8"/></bsdf></bsdf>')
    scene = load(tmp_path, body=f'<shape type="rectangle" id="card">{two}</shape>')
    front, back = scene.objects[-2:]
    assert (front.name, back.name) == ("card/front", "card/back")
    assert front.material.sided == back.material.sided == "one"
    np.testing.assert_allclose(front.material.kd, [0.8, 0.1, 0.1])
    np.testing.assert_allclose(back.material.kd, [0.1, 0.1, 0.8])
    np.testing.assert_allclose(back.mesh.face_normals, -front.mesh.face_normals)
    gap = (front.mesh.vertices - back.mesh.vertices) @ [0.0, 0.0, 1.0]
    assert 0 < gap.min() and gap.max() < 1e-3  # just behind the front
    mixed = two.replace('<bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.1, 0.8"/></bsdf>',
                        '<bsdf type="conductor"/>')
    with pytest.raises(InputError, match=r"s.xml:10: <bsdf type=\"twosided\">: a twosided of two BSDFs .*diffuse"):
        load(tmp_path, body=f'<shape type="rectangle">{mixed}</shape>')


def test_a_constant_environment_is_an_environment_light_of_its_radiance(tmp_path):
    """Mitsuba's constant emitter: an environment light whose radiance is the constant in every
    direction (no object added); beside an envmap, their sum in one map."""
    from blockhash.scene.model import EnvironmentLight

    light = '<emitter type="constant"><rgb name="radiance" value="0.5, 0.6, 0.7"/></emitter>'
    scene = load(tmp_path, light=light)
    env = scene.lights[-1]
    assert isinstance(env, EnvironmentLight) and env.name == "constant-environment"
    d = np.random.default_rng(0).normal(size=(50, 3))
    np.testing.assert_allclose(env.emitted(d / np.linalg.norm(d, axis=1, keepdims=True)),
                               np.broadcast_to([0.5, 0.6, 0.7], (50, 3)))
    np.testing.assert_allclose(env.integral, 4 * np.pi * np.array([0.5, 0.6, 0.7]))
    assert "constant-environment" not in [o.name for o in scene.objects]
    assert load(tmp_path, light='<emitter type="constant"/>').lights[-1].image.max() == 1.0
    with pytest.raises(InputError, match=r"s.xml:8: <emitter type=\"constant\">: a second constant"):
        load(tmp_path, light='<emitter type="constant"/><emitter type="constant"/>')


@pytest.mark.parametrize("depth, events", [(None, 64), (-1, 64), (3, None), (9, None)])
def test_an_unbounded_max_depth_lets_the_indirect_photons_go_on(tmp_path, depth, events):
    """Mitsuba's unbounded depth (-1, its default) ends a path by Russian roulette alone: the
    indirect photons may meet 64 surface events; a finite max_depth keeps blockhash's rule
    (max_bounces + 1, max_bounces from max_depth)."""
    import warnings

    top = "" if depth is None else f'<integrator type="path"><integer name="max_depth" value="{depth}"/></integrator>'
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert load(tmp_path, top=top).photons.indirect_events == events


@needs_mitsuba
def test_mitsubas_default_bsdf_is_black_on_an_emitting_shape_and_grey_elsewhere(tmp_path):
    """What blockhash's import takes as a shape's BSDF when the file gives none, held to what
    Mitsuba itself builds: a diffuse of 0 on a shape that emits (its light reflects nothing:
    a default of 0.5 there rendered a lamp over a floor 3% brighter than Mitsuba), of 0.5
    elsewhere."""
    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, _ = load_mitsuba_module()
    body = ('<shape type="rectangle" id="lamp"><emitter type="area"><rgb name="radiance" '
            'value="1"/></emitter></shape><shape type="rectangle" id="plain"/>')
    scene = load(tmp_path, body=body)
    ours = {o.name: float(o.material.kd[0]) for o in scene.objects if o.name in ("lamp", "plain")}
    theirs = mi.load_string(f'<scene version="3.0.0">{body}</scene>')
    params = mi.traverse(theirs)
    got = {}
    for shape in theirs.shapes():
        key = [k for k in params.keys() if k.startswith(shape.id() + ".bsdf.reflectance")]
        got[shape.id()] = float(np.ravel(params[key[0]])[0])
    assert ours == pytest.approx(got) and got == pytest.approx({"lamp": 0.0, "plain": 0.5})
