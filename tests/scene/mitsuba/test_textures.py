"""Mitsuba's checkerboard on a diffuse reflectance (blockhash/scene/mitsuba/textures.py): its
colours where Mitsuba's texture has them, the cut of each triangle along the checks' borders
(area kept, every piece of one colour), the shapes it applies to, and what is refused."""

import numpy as np
import pytest
from test_mitsuba_mapping import load  # the shared scene text

from blockhash.errors import InputError
from blockhash.reference.mitsuba import mitsuba_available
from blockhash.scene.mitsuba.textures import Checkerboard, split

needs_mitsuba = pytest.mark.skipif(not mitsuba_available()[0], reason=mitsuba_available()[1])
TO_UV = '<transform name="to_uv"><scale x="2" y="3"/><translate x="0.1" y="0.2"/><rotate z="1" angle="30"/></transform>'


@needs_mitsuba
def test_the_checks_colours_are_where_mitsubas_texture_has_them(tmp_path):
    from blockhash.reference.mitsuba import load_mitsuba_module
    from blockhash.scene.mitsuba.textures import checkerboard
    from blockhash.scene.mitsuba.xml_values import XmlReader, parse

    mi, _ = load_mitsuba_module()
    text = (f'<texture type="checkerboard"><rgb name="color0" value="1, 0, 0"/>'
            f'<rgb name="color1" value="0, 0, 1"/>{TO_UV}</texture>')
    theirs = mi.load_string(text.replace("<texture ", '<texture version="3.0.0" ', 1))
    path = tmp_path / "t.xml"
    path.write_text(text)
    root, lines = parse(path)
    ours = checkerboard(XmlReader(path, lines), root)
    uv = np.random.default_rng(1).uniform(-2, 2, (400, 2))
    si = mi.SurfaceInteraction3f()
    want = []
    for u, v in uv:
        si.uv = mi.Point2f(float(u), float(v))
        want.append(np.ravel(theirs.eval(si))[0] > 0.5)  # red: color0
    assert (ours.is_color0(ours.uv(uv)) == np.array(want)).mean() == 1.0


def test_a_cut_keeps_the_area_and_each_piece_is_one_colour():
    rng = np.random.default_rng(0)
    uv = rng.uniform(-1, 2, (300, 2))
    faces = rng.integers(0, 300, (200, 3))
    checker = Checkerboard(np.ones(3), np.zeros(3), np.array([[1.3, 0.4, 0.1], [-0.2, 0.9, 0.3]]))

    def area(tri, bary):
        p = np.einsum("kij,kjd->kid", bary, uv[faces[tri]])
        e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
        return 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])

    pieces = split(faces, uv, checker)
    whole = area(np.arange(len(faces)), np.broadcast_to(np.eye(3), (len(faces), 3, 3))).sum()
    assert sum(area(*p).sum() for p in pieces) == pytest.approx(whole, rel=1e-12)
    for (tri, bary), colour0 in zip(pieces, (True, False)):
        w = rng.dirichlet([1, 1, 1], len(tri))
        points = np.einsum("kj,kjd->kd", np.einsum("ki,kij->kj", w, bary), uv[faces[tri]])
        assert (checker.is_color0(checker.uv(points)) == colour0).all()


def test_a_checkered_rectangle_becomes_two_objects_of_the_checks_colours(tmp_path):
    body = ('<shape type="rectangle" id="board"><bsdf type="twosided"><bsdf type="diffuse">'
            '<ref name="reflectance" id="checks"/></bsdf></bsdf></shape>'
            '<texture type="checkerboard" id="checks"><transform name="to_uv"><scale value="2"/>'
            '</transform></texture>')
    scene = load(tmp_path, body=body)
    a, b = scene.objects[-2:]
    assert (a.name, b.name) == ("board/color0", "board/color1")
    np.testing.assert_allclose(a.material.kd, 0.4)  # Mitsuba's defaults
    np.testing.assert_allclose(b.material.kd, 0.2)
    assert a.material.sided == "two"
    # 4 x 4 checks on the [-1, 1]^2 rectangle: half the area each
    assert a.mesh.area == pytest.approx(2.0) and b.mesh.area == pytest.approx(2.0)


@pytest.mark.parametrize("body, match", [
    ('<shape type="cube"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf></shape>',
     r"s.xml:10: <shape type=\"cube\">: a checkerboard on a cube: .*rectangle, obj, ply, serialized, sphere, disk, cylinder"),
    ('<shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"/></bsdf></shape>',
     r"s.xml:10: <texture type=\"bitmap\" name=\"reflectance\">: a bitmap needs its image"),
    ('<shape type="rectangle"><bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"/></bsdf></shape>',
     r"s.xml:10: <texture type=\"mesh_attribute\" name=\"reflectance\">: a mesh_attribute texture is not "
     r"supported; supported: checkerboard and bitmap"),
    ('<shape type="rectangle"><bsdf type="diffuse"><ref name="reflectance" id="nope"/></bsdf></shape>',
     r"s.xml:10: <ref name=\"reflectance\">: no texture with id 'nope'"),
    ('<shape type="rectangle"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf>'
     '<emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>',
     r"s.xml:10: <emitter type=\"area\">: an area emitter on a shape with a textured reflectance"),
])
def test_what_a_checkerboard_cannot_be_on_is_refused_by_line(tmp_path, body, match):
    with pytest.raises(InputError, match=match):
        load(tmp_path, body=body)


def test_an_obj_keeps_its_normals_and_mitsubas_flipped_texture_coordinates(tmp_path):
    """An OBJ's ``vt`` with v flipped, as Mitsuba's OBJ loader takes them (a square whose v
    runs 0 .. 0.4 in the file lies at 0.6 .. 1 in Mitsuba: all color1, where the file's own v
    would give all color0), and its ``vn`` kept on both colours' pieces."""
    (tmp_path / "square.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
        "vt 0 0\nvt 0.4 0\nvt 0.4 0.4\nvt 0 0.4\n"
        "vn 0 0.6 0.8\n"
        "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")
    body = ('<shape type="obj" id="sq"><string name="filename" value="square.obj"/>'
            '<bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf></shape>')
    scene = load(tmp_path, body=body)
    [square] = [o for o in scene.objects if o.name.startswith("sq/")]
    assert square.name == "sq/color1"
    np.testing.assert_allclose(square.mesh.vertex_normals, np.tile([0.0, 0.6, 0.8], (len(square.mesh.vertices), 1)), atol=1e-9)


@pytest.mark.parametrize("shape, local", [
    ('<shape type="sphere"><point name="center" x="0.5" y="0" z="1"/><float name="radius" value="2"/>',
     lambda p: (p - [0.5, 0.0, 1.0]) / 2.0),
    ('<shape type="disk"><transform name="to_world"><scale value="3"/></transform>', lambda p: p / 3.0),
    ('<shape type="cylinder"><point name="p0" x="0" y="0" z="0"/><point name="p1" x="0" y="1" z="0"/>',
     None),
])
def test_a_checkerboard_on_an_analytic_shape_follows_mitsubas_parametrisation(tmp_path, shape, local):
    """Each piece's colour is the checkerboard's at Mitsuba's own coordinates of the piece's
    centre (the sphere's (phi / 2 pi, theta / pi), the disk's (r, phi / 2 pi), the cylinder's
    azimuth in Mitsuba's frame of its axis and its height), but where a tessellated border
    strays from the analytic one (by area)."""
    from blockhash.scene.mitsuba.shapes import _mitsuba_frame, _phi

    scaled = '<transform name="to_uv"><scale x="4" y="6"/></transform>'
    texture = f'<texture type="checkerboard" name="reflectance">{scaled}</texture>'
    scene = load(tmp_path, body=f'{shape}<bsdf type="diffuse">{texture}</bsdf></shape>')
    checker = Checkerboard(np.zeros(3), np.ones(3), np.array([[4.0, 0.0, 0.0], [0.0, 6.0, 0.0]]))
    pieces = [next(o for o in scene.objects if o.name.endswith(f"/color{k}")) for k in (0, 1)]
    agree = []
    for obj, want in zip(pieces, (True, False)):
        centre = np.asarray(obj.mesh.triangles_center, dtype=np.float64)
        if local is None:  # the cylinder along +y, from the origin, radius 1
            s_axis, t_axis = _mitsuba_frame(np.array([0.0, 1.0, 0.0]))
            uv = np.stack([_phi(centre @ t_axis, centre @ s_axis), centre[:, 1]], axis=1)
        else:
            q = local(centre)
            q /= np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-12) if "sphere" in shape else 1.0
            phi = _phi(q[:, 0], q[:, 1])
            uv = (np.stack([phi, np.arccos(np.clip(q[:, 2], -1, 1)) / np.pi], axis=1)
                  if "sphere" in shape else np.stack([np.hypot(q[:, 0], q[:, 1]), phi], axis=1))
        area = np.asarray(obj.mesh.area_faces)
        agree.append((area * (checker.is_color0(checker.uv(uv)) == want), area))
    right, total = (sum(float(a.sum()) for a in col) for col in zip(*agree))
    assert right / total > 0.97  # by area: the disk's rim reaches past r = 1 by 10^-4
