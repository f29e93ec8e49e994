"""One-sided and two-sided diffuse surfaces rendered by blockhash's import and by Mitsuba from
the same Mitsuba 3 XML file agree: a bare ``diffuse`` is black seen or lit from its back,
a ``twosided`` one is lit on both faces, and ``flip_normals`` turns the front.

* ``floor``: ``mirror.xml``'s scene (a spot light on a tilted mirror whose reflection is the
  caustic on the floor, and a point light), its floor turned over by ``flip_normals``: bare,
  black in both (direct and caustic); wrapped in ``twosided``, lit in both, compared as
  ``test_mitsuba_xml_scenes`` compares (direct sums, the caustic region's light).
* ``tube``: an open tube (one-sided, normals outward) on a floor, seen from above, so that
  its outside (front) and its inside (back, through the opening) are both in the image; bare,
  turned by ``flip_normals``, and ``twosided``.  Mitsuba's path tracer at depth 2 (direct
  light only: blockhash has no diffuse interreflection) against the direct layer, over the
  image and over the tube's own pixels.

Needs the extra blockhash[mitsuba]; skipped without it, unless BLOCKHASH_REQUIRE_MITSUBA is
set (CI sets it), where it fails instead."""

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh
from conftest import mitsuba_or_skip
from test_mitsuba_xml_scenes import mitsuba_layers

from blockhash.scene.camera import Pinhole
from blockhash.scene.loader import load_scene

HERE = Path(__file__).resolve().parent / "mitsuba_xml"
#: Limits, over measured at these settings (photon seed 1, Mitsuba seed 3): the direct
#: layer's sum within 0.06% of Mitsuba's path tracer on the twosided floor and 0.03% on the
#: tube's scenes, 0.22-0.64% on the tube's own pixels; the caustic region's light within
#: 0.13% of Mitsuba's particle tracer.  Read as two-sided, the flipped floor shows 250 in
#: the direct layer and 211 in the caustic where Mitsuba is black, and the tube's pixels are
#: 50% (flipped) and 176% too bright.
DIRECT_LIMIT = 0.01
CAUSTIC_LIMIT = 0.05
pytestmark = pytest.mark.gl

FLOOR_BSDF = '<bsdf type="diffuse"><spectrum name="reflectance" value="0.5"/></bsdf>'
DIFFUSE = '<bsdf type="diffuse"><rgb name="reflectance" value="{kd}"/></bsdf>'
TWOSIDED = '<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="{kd}"/></bsdf></bsdf>'
FLIP = '<boolean name="flip_normals" value="true"/>'

TUBE_XML = """<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, 2.2, 1.8" target="0, 0.1, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="40"/>
      <rfilter type="box"/></film>
  </sensor>
  <emitter type="point"><point name="position" value="-0.6, 2.0, 1.0"/><float name="intensity" value="3"/></emitter>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="2"/></transform>
    {floor}
  </shape>
  <shape type="ply" id="tube">
    <string name="filename" value="tube.ply"/>
    {tube}
  </shape>
</scene>
"""


@pytest.fixture(scope="module", autouse=True)
def needs_mitsuba():
    mitsuba_or_skip()


def tube_mesh(radius=0.5, height=0.6, segments=48) -> trimesh.Trimesh:
    """An open tube standing on y = 0, counter-clockwise seen from outside (its face normals
    point outward)."""
    a = 2 * np.pi * np.arange(segments) / segments
    bottom = np.stack([radius * np.cos(a), np.zeros(segments), radius * np.sin(a)], axis=1)
    i, j = np.arange(segments), (np.arange(segments) + 1) % segments
    n = segments
    faces = np.concatenate([np.stack([i, n + i, j], 1), np.stack([j, n + i, n + j], 1)])
    mesh = trimesh.Trimesh(np.concatenate([bottom, bottom + (0, height, 0)]), faces, process=False)
    assert (np.einsum("ij,ij->i", mesh.face_normals, mesh.triangles_center * (1, 0, 1)) > 0).all()
    return mesh


def tube_file(tmp_path, tube: str) -> Path:
    (tmp_path / "tube.ply").write_bytes(tube_mesh().export(file_type="ply", encoding="binary"))
    path = tmp_path / "tube.xml"
    path.write_text(TUBE_XML.format(floor=DIFFUSE.format(kd=0.5), tube=tube))
    return path


def floor_file(tmp_path, floor: str) -> Path:
    path = tmp_path / "floor.xml"
    path.write_text((HERE / "mirror.xml").read_text().replace(FLOOR_BSDF, floor))
    assert path.read_text() != (HERE / "mirror.xml").read_text()
    return path


def render(scene):
    import blockhash
    from blockhash import LookupOptions

    with warnings.catch_warnings():
        # the tube casts no caustic, and the back of the flipped floor takes none
        warnings.filterwarnings("ignore", message="rendering direct light only")
        image = blockhash.render(scene, photons=40_000, seed=1,
                                 lookup=LookupOptions(method="cpu"))
    return image.direct.astype(np.float64), image.caustic.astype(np.float64)


def first_hits(scene, name):
    """(h, w) bool: the ray through each pixel centre meets object ``name`` first."""
    from blockhash.frame.scene_rays import SceneRays

    pin = Pinhole.of(scene.camera)
    d = pin.pixel_rays()
    _, _, _, obj, _ = SceneRays(scene.objects).first_hit(np.broadcast_to(pin.eye, d.shape).copy(), d)
    index = [o.name for o in scene.objects].index(name)
    return (obj == index).reshape(pin.height, pin.width)


def relative(a, b):
    return abs(a - b) / b


def test_a_one_sided_floor_seen_from_its_back_is_black_in_both(tmp_path):
    path = floor_file(tmp_path, FLIP + DIFFUSE.format(kd=0.5))
    scene = load_scene(path)
    assert scene.objects[0].material.sided == "one"
    direct, caustic = render(scene)
    path_tracer, particle_tracer = mitsuba_layers(path, scene.photons.max_bounces + 2)
    assert path_tracer.sum() == 0.0 and particle_tracer.sum() == 0.0  # Mitsuba: black
    assert direct.sum() == 0.0 and caustic.sum() == 0.0
    floor = scene.objects[0]  # the test can fail: the same floor two-sided is lit
    two = replace(scene, objects=(replace(floor, material=replace(floor.material, sided="two")),
                                  scene.objects[1]))
    assert min(a.sum() for a in render(two)) > 100


def test_a_twosided_floor_seen_from_its_back_is_lit_in_both(tmp_path):
    path = floor_file(tmp_path, FLIP + TWOSIDED.format(kd=0.5))
    scene = load_scene(path)
    assert scene.objects[0].material.sided == "two"
    direct, caustic = render(scene)
    path_tracer, particle_tracer = mitsuba_layers(path, scene.photons.max_bounces + 2)
    assert path_tracer.sum() > 0
    rel = relative(direct.sum(), path_tracer.sum())
    assert rel < DIRECT_LIMIT, f"direct light differs by {rel:.4f}"
    lum = caustic.sum(axis=2)
    region = lum > 0.1 * lum.max()
    assert region.sum() > 10
    rel = relative((direct + caustic)[region].sum(), particle_tracer[region].sum())
    assert rel < CAUSTIC_LIMIT, f"the caustic region's light differs by {rel:.4f}"


@pytest.mark.parametrize("tube, sided", [
    (DIFFUSE.format(kd=0.7), "one"),
    (FLIP + DIFFUSE.format(kd=0.7), "one"),
    (TWOSIDED.format(kd=0.7), "two"),
], ids=["diffuse", "flipped diffuse", "twosided"])
def test_an_open_mesh_seen_from_both_sides_agrees(tmp_path, tube, sided):
    path = tube_file(tmp_path, tube)
    scene = load_scene(path)
    assert [o.material.sided for o in scene.objects] == ["one", sided]
    direct, _ = render(scene)
    path_tracer, _ = mitsuba_layers(path, 2)  # direct light only, as blockhash's direct layer
    rel = relative(direct.sum(), path_tracer.sum())
    assert rel < DIRECT_LIMIT, f"direct light differs by {rel:.4f}"
    tube_pixels = first_hits(scene, "tube")
    assert tube_pixels.sum() > 100
    rel = relative(direct[tube_pixels].sum(), path_tracer[tube_pixels].sum())
    assert rel < DIRECT_LIMIT, f"direct light on the tube differs by {rel:.4f}"
    if sided == "one":  # the test can fail: the same tube two-sided is far off
        tube_obj = scene.objects[1]
        two = replace(scene, objects=(scene.objects[0], replace(
            tube_obj, material=replace(tube_obj.material, sided="two"))))
        wrong, _ = render(two)
        assert relative(wrong[tube_pixels].sum(), path_tracer[tube_pixels].sum()) > 5 * DIRECT_LIMIT
