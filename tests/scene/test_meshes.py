"""Generated meshes: the floor rectangle, the mirror ring and the bust."""

import time

import numpy as np
import pytest
import trimesh

from blockhash.errors import InputError
from blockhash.scene import meshes


def _radial(vertices):
    """Horizontal unit vectors from the y axis, and the distances to it."""
    h = vertices.copy()
    h[:, 1] = 0.0
    r = np.linalg.norm(h, axis=1)
    return h / np.where(r > 0.0, r, 1.0)[:, None], r


def _faces_agree_with_normals(mesh):
    """Cosine between each face's winding normal and its vertices' mean normal."""
    mean = mesh.vertex_normals[mesh.faces].mean(axis=1)
    mean /= np.linalg.norm(mean, axis=1, keepdims=True)
    return np.einsum("ij,ij->i", mesh.face_normals, mean)


# --------------------------------------------------------------------------- rectangle

def test_rectangle_extents_and_normal():
    m = meshes.rectangle(x=(-1.5, 1.25), z=(-0.5, 2.0), y=0.25)
    assert m.bounds.tolist() == [[-1.5, 0.25, -0.5], [1.25, 0.25, 2.0]]
    assert len(m.faces) == 2
    assert np.allclose(m.face_normals, [0.0, 1.0, 0.0])
    assert np.array_equal(m.vertex_normals, np.tile([0.0, 1.0, 0.0], (4, 1)))
    assert m.area == pytest.approx(2.75 * 2.5)


@pytest.mark.parametrize("kwargs, match", [
    (dict(x=(1.0, -1.0), z=(-1.0, 1.0)), r"rectangle: extents must be increasing"),
    (dict(x=(0.0, 0.0), z=(-1.0, 1.0)), r"min < max"),
    (dict(x=(-1.0, 1.0), z=(-1.0, 1.0), y=float("nan")), r"rectangle: .* must be finite"),
])
def test_rectangle_rejects_bad_extents(kwargs, match):
    with pytest.raises(InputError, match=match):
        meshes.rectangle(**kwargs)


# --------------------------------------------------------------------------- ring

@pytest.fixture(scope="module")
def ring():
    return meshes.ring(0.50, 0.53, 0.30, 256)


def test_ring_has_256_segments(ring):
    angles = np.round(np.arctan2(ring.vertices[:, 2], ring.vertices[:, 0]), 9)
    assert len(np.unique(angles)) == 256
    # inner wall, outer wall, rim: one quad (two triangles) per segment each
    assert len(ring.faces) == 3 * 2 * 256
    assert len(ring.vertices) == 3 * 2 * 256


def test_ring_dimensions_exact_on_vertices(ring):
    _, r = _radial(ring.vertices)
    assert set(np.round(r, 12)) == {0.50, 0.53}
    assert set(ring.vertices[:, 1]) == {0.0, 0.30}
    assert np.allclose(r[r < 0.515], 0.50, rtol=0, atol=1e-15)
    assert np.allclose(r[r > 0.515], 0.53, rtol=0, atol=1e-15)


def test_ring_walls_have_radial_normals(ring):
    n = ring.vertex_normals
    radial, r = _radial(ring.vertices)
    wall = np.abs(n[:, 1]) < 1e-12
    assert wall.sum() == 4 * 256
    dots = np.einsum("ij,ij->i", n[wall], radial[wall])
    inner = r[wall] < 0.515
    assert np.allclose(dots[inner], -1.0, rtol=0, atol=1e-12)     # toward the axis
    assert np.allclose(dots[~inner], 1.0, rtol=0, atol=1e-12)     # away from it


def test_ring_wall_normals_are_smooth_not_faceted(ring):
    """Each wall triangle's vertex normals are the radial directions at its corners,
    so they differ from the flat face normal by up to half a segment's angle."""
    n = ring.vertex_normals[ring.faces]                       # (m, 3, 3)
    wall = np.abs(n[:, :, 1]).max(axis=1) < 1e-12
    cos = np.einsum("ij,ikj->ik", ring.face_normals[wall], n[wall])
    half_segment = np.pi / 256
    assert np.allclose(cos, np.cos(half_segment), atol=1e-9)
    assert not np.allclose(cos, 1.0)


def test_ring_rim_is_flat_and_faces_up(ring):
    n = ring.vertex_normals
    rim = n[:, 1] > 0.5
    assert rim.sum() == 2 * 256
    assert np.array_equal(n[rim], np.tile([0.0, 1.0, 0.0], (rim.sum(), 1)))
    assert np.all(ring.vertices[rim, 1] == 0.30)
    # the rim's vertices are separate from the walls' (sharp edges): same positions twice
    top = ring.vertices[:, 1] == 0.30
    assert len(np.unique(ring.vertices[top], axis=0)) == top.sum() // 2


def test_ring_winding_agrees_with_normals(ring):
    assert _faces_agree_with_normals(ring).min() > 0.99


def test_ring_bottom_closes_the_shell():
    m = meshes.ring(0.5, 0.53, 0.3, 64, center=(1.0, 2.0, -3.0), bottom=True)
    assert len(m.faces) == 4 * 2 * 64
    assert np.allclose(m.vertices[:, 1].min(), 2.0)
    bottom = m.vertex_normals[:, 1] < -0.5
    assert bottom.sum() == 2 * 64 and np.all(m.vertices[bottom, 1] == 2.0)
    assert _faces_agree_with_normals(m).min() > 0.99
    closed = trimesh.Trimesh(m.vertices, m.faces)              # merges the parts' vertices
    assert closed.is_watertight and closed.is_winding_consistent
    prism = 64 / 2 * np.sin(2 * np.pi / 64) * (0.53 ** 2 - 0.5 ** 2) * 0.3
    assert closed.volume == pytest.approx(prism, rel=1e-9)     # outward: positive volume


def test_ring_normals_survive_trimesh_queries(ring):
    """trimesh keeps given vertex normals only while the geometry is unchanged."""
    before = ring.vertex_normals.copy()
    _ = ring.bounds, ring.area, ring.face_normals, ring.is_watertight, ring.edges_unique
    ring.ray.intersects_any([[0.0, 0.15, 0.0]], [[1.0, 0.0, 0.0]])
    assert np.array_equal(ring.vertex_normals, before)


@pytest.mark.parametrize("args, match", [
    ((0.53, 0.50, 0.3), r"ring: inner_radius=0.53 must be < outer_radius=0.5"),
    ((0.5, 0.53, 0.0), r"ring: height must be a finite number > 0; got 0.0"),
    ((-0.5, 0.53, 0.3), r"ring: inner_radius must be a finite number > 0"),
    ((0.5, 0.53, 0.3, 2), r"ring: segments must be an integer >= 3; got 2"),
    ((0.5, 0.53, 0.3, 16, (0.0, 1.0)), r"ring: center must be 3 finite numbers"),
])
def test_ring_rejects_bad_parameters(args, match):
    with pytest.raises(InputError, match=match):
        meshes.ring(*args)


# --------------------------------------------------------------------------- bust

@pytest.fixture(scope="module")
def bust():
    return meshes.bust()


def test_bust_is_highly_tessellated(bust):
    assert len(bust.faces) >= meshes.MIN_BUST_TRIANGLES
    assert len(bust.faces) == 2 * 384 * (200 - 2)


def test_bust_is_closed_and_wound_outwards(bust):
    assert bust.is_watertight
    assert bust.is_winding_consistent
    assert bust.volume > 0.0                 # outward winding gives a positive volume
    assert _faces_agree_with_normals(bust).min() > 0.9


def test_bust_normals_point_away_from_the_axis(bust):
    """Every cross-section is convex around the y axis, so off the flat base and
    the head's top every normal has an outward horizontal component."""
    v, n = bust.vertices, bust.vertex_normals
    side = (v[:, 1] > 0.02) & (v[:, 1] < 0.62)
    assert side.sum() > 0.6 * len(v)
    outward = n[side, 0] * v[side, 0] + n[side, 2] * v[side, 2]
    assert outward.min() > 0.0
    base = (v[:, 1] == 0.0) & (np.hypot(v[:, 0], v[:, 2]) < 0.08)   # inside the rounded edge
    assert base.sum() > 1000
    assert np.allclose(n[base], [0.0, -1.0, 0.0])
    top = np.argmax(v[:, 1])
    assert np.allclose(n[top], [0.0, 1.0, 0.0])


def test_bust_normals_are_smooth(bust):
    """Neighbouring vertex normals differ by little above the base's rounded edge."""
    n, e = bust.vertex_normals, bust.edges_unique
    above = bust.vertices[e[:, 0], 1] > 0.01
    cos = np.einsum("ij,ij->i", n[e[above, 0]], n[e[above, 1]])
    assert cos.min() > np.cos(np.radians(20.0))
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)


def test_bust_shape_has_neck_shoulders_chest_and_head(bust):
    d = meshes.bust_dimensions()
    v = bust.vertices
    _, r = _radial(v)
    neck = (v[:, 1] >= d.neck_y[0]) & (v[:, 1] <= d.neck_y[1])
    assert d.neck_radius == pytest.approx(r[neck].max())
    head = v[:, 1] > d.neck_y[1] + 0.05
    assert r[head].max() > d.neck_radius              # the head is wider than the neck
    assert d.shoulder_half_width > 2.5 * d.neck_radius
    assert d.height == pytest.approx(v[:, 1].max())
    assert d.neck_y[1] < d.height and d.shoulder_y < d.neck_y[0]
    # the chest below the neck faces forward and up: where the caustic lands
    front = (v[:, 2] > 0.05) & (np.abs(v[:, 0]) < 0.05) & (v[:, 1] > 0.27) & (v[:, 1] < 0.33)
    assert front.sum() > 100
    nf = bust.vertex_normals[front]
    assert np.all(nf[:, 2] > 0.5) and np.all(nf[:, 1] > 0.1)


def test_bust_center_moves_it_and_calls_are_independent():
    a = meshes.bust(center=(0.5, 0.1, -0.2), segments=32, rings=20)
    b = meshes.bust(segments=32, rings=20)
    assert np.allclose(a.vertices - b.vertices, [0.5, 0.1, -0.2])
    assert np.array_equal(a.vertex_normals, b.vertex_normals)
    b.vertices[0] += 1.0                                   # a mesh owns its arrays
    assert np.allclose(meshes.bust(segments=32, rings=20).vertices[0], [0.0, 0.0, 0.0])


def test_bust_generation_is_fast():
    meshes._bust_arrays.cache_clear()
    start = time.perf_counter()
    meshes.bust()
    assert time.perf_counter() - start < 5.0


@pytest.mark.parametrize("kwargs, match", [
    (dict(segments=4), r"bust: segments must be an integer >= 8; got 4"),
    (dict(rings=2), r"bust: rings must be an integer >= 4; got 2"),
    (dict(center=(0.0, float("inf"), 0.0)), r"bust: center must be 3 finite numbers"),
])
def test_bust_rejects_bad_parameters(kwargs, match):
    with pytest.raises(InputError, match=match):
        meshes.bust(**kwargs)


# --------------------------------------------------------------------------- files, placement

def _write_ply_with_normals(path, mesh, normals):
    v, f = mesh.vertices, mesh.faces
    lines = ["ply", "format ascii 1.0", f"element vertex {len(v)}",
             *[f"property float {c}" for c in ("x", "y", "z", "nx", "ny", "nz")],
             f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    lines += [" ".join(map(str, [*p, *n])) for p, n in zip(v, normals)]
    lines += ["3 " + " ".join(map(str, t)) for t in f]
    path.write_text("\n".join(lines) + "\n")


def test_load_mesh_keeps_ply_normals(tmp_path):
    quad = meshes.rectangle(x=(0.0, 1.0), z=(0.0, 1.0))
    tilted = np.tile([0.0, 0.6, 0.8], (4, 1))
    _write_ply_with_normals(tmp_path / "quad.ply", quad, tilted)
    loaded = meshes.load_mesh(tmp_path / "quad.ply")
    assert np.allclose(loaded.vertices, quad.vertices)
    assert np.allclose(loaded.vertex_normals, tilted, atol=1e-6)
    assert np.allclose(meshes.load_mesh(tmp_path / "quad.ply", normals="smooth").vertex_normals,
                       [0.0, 1.0, 0.0])


@pytest.mark.parametrize("content, normals, match", [
    ("v 0 0 0\n", "auto", r"the mesh file '.*bad\.obj' has no triangles"),
    ("f 1 2 3\n", "sharp", r"normals='sharp' is not a normal mode; expected one of 'auto'"),
])
def test_load_mesh_errors(tmp_path, content, normals, match):
    (tmp_path / "bad.obj").write_text(content)
    with pytest.raises(InputError, match=match):
        meshes.load_mesh(tmp_path / "bad.obj", normals=normals)


def test_placed_moves_vertices_and_turns_normals():
    ring = meshes.ring(0.5, 0.53, 0.3, 16)
    assert meshes.placed(ring) is ring
    moved = meshes.placed(ring, scale=2.0, rotate_deg=(90.0, 0.0, 0.0), translate=(0.0, 1.0, 0.0))
    # about x by 90 degrees: +y goes to +z; the base circle (y = 0) stays at y = 1 after the shift
    rim = ring.vertex_normals[:, 1] > 0.5
    assert np.allclose(moved.vertex_normals[rim], [0.0, 0.0, 1.0])
    assert np.allclose(moved.vertices[rim, 2], 0.6)
    assert np.allclose(meshes.rotation((0.0, 90.0, 0.0)) @ [1.0, 0.0, 0.0], [0.0, 0.0, -1.0])
    with pytest.raises(InputError, match=r"scale must be a finite number > 0; got 0\.0"):
        meshes.placed(ring, scale=0.0)


def test_text_segment_count_is_an_input_error_not_a_crash():
    with pytest.raises(InputError, match=r"segments must be an integer >= 3; got 'x'"):
        meshes.ring(0.5, 0.53, 0.3, "x")
