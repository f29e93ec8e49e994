"""Hostile input: malformed scene files and command lines get a one-line error that names
the file, key or flag, and a non-zero exit; never a traceback (docs/extremes.md)."""

from pathlib import Path

import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from blockhash import InputError
from blockhash.cli import main
from blockhash.scene.loader import load_scene, parse_scene

pytestmark = pytest.mark.gl  # tests here open GL contexts (EGL or OSMesa)

RING = Path(__file__).resolve().parents[1] / "scenes" / "ring.toml"
RING_TEXT = RING.read_text()


def run_cli(capsys, argv):
    """(exit status, stderr) of the command line, argparse's own exits included."""
    try:
        status = main(argv)
    except SystemExit as exc:
        status = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return status, err


# --------------------------------------------------------------------------- command line

@pytest.mark.parametrize("argv, match", [
    (["render", "--bogus", str(RING)], r"unrecognized arguments: --bogus"),
    (["render", str(RING), "--k", "many"], r"argument --k: invalid int value: 'many'"),
    (["render", str(RING), "--size", "0x8"], r"--size '0x8': width and height must be >= 1"),
    (["render", "no/such.toml"], r"no/such\.toml: scene file not found"),
    (["render", str(RING), "-o", "/no/such/folder/out.exr"],
     r"--output /no/such/folder/out\.exr: the folder /no/such/folder does not exist"),
    (["render", str(RING), "-o", "out.png"], r"--output out\.png: expected a \.exr file name"),
    (["render", str(RING), "--method", "magic"], r"argument --method: invalid choice: 'magic'"),
    (["index", "--photons", "100", "--k", "0"], r"k=0 is out of range"),
    (["frobnicate"], r"invalid choice: 'frobnicate'"),
])
def test_bad_command_lines_get_one_line_errors(capsys, argv, match):
    status, err = run_cli(capsys, argv)
    assert status == 2
    last = err.strip().splitlines()[-1]
    assert pytest.importorskip("re").search(match, last), last


def test_unwritable_output_is_refused_before_rendering(capsys, tmp_path, monkeypatch):
    import blockhash.passes.pipeline as pipeline

    monkeypatch.setattr(pipeline, "render_scene", lambda *a, **k: pytest.fail("rendered anyway"))
    folder = tmp_path / "dir.exr"
    folder.mkdir()
    status, err = run_cli(capsys, ["render", str(RING), "-o", str(folder)])
    assert status == 2 and f"--output {folder}: is a directory" in err
    monkeypatch.setattr("os.access", lambda *a, **k: False)  # as for a read-only folder
    status, err = run_cli(capsys, ["render", str(RING), "-o", str(tmp_path / "out.exr")])
    assert status == 2 and "not writable (permission denied); give a writable path" in err


def test_an_os_error_is_one_line_not_a_traceback(capsys, monkeypatch):
    import blockhash.cli.images as images

    def boom(args):
        raise PermissionError(13, "Permission denied", "/some/file.exr")

    monkeypatch.setattr(images, "cmd_info", boom)
    status, err = run_cli(capsys, ["info"])
    assert status == 2
    assert err.strip() == ("blockhash info: error: /some/file.exr Permission denied; check the path "
                           "and its permissions")


# --------------------------------------------------------------------------- scene files

@pytest.mark.parametrize("old, new, match", [
    ("width = 512", "width = -512", r"camera\.width"),
    ("width = 512", 'width = "wide"', r"camera\.width"),
    ("fov_y_deg = 38.0", "fov_y_deg = nan", r"camera\.fov_y_deg"),
    ("inner_radius = 0.50", "inner_radius = -0.5", r"inner_radius"),
    ("[camera]", "[camera\n", r"TOML syntax error"),
    ("eye = [0.0, 1.9, 1.6]", "eye = [0.0, inf, 1.6]", r"camera\.eye"),
    ("eye = [0.0, 1.9, 1.6]", "", r"camera\.eye"),
    ("power = [100.0, 100.0, 100.0]", "power = -1.0", r"lights\[0\]\.power"),
    ('kind = "ring"', 'kind = "torus"', r"objects\[1\]\.shape\.kind"),
])
def test_malformed_scene_values_name_file_and_key(old, new, match):
    assert old in RING_TEXT
    with pytest.raises(InputError, match=r"ring\.toml: .*" + match):
        parse_scene(RING_TEXT.replace(old, new, 1), path=RING)


def _mesh_scene(tmp_path, mesh_text, suffix=".obj"):
    (tmp_path / f"m{suffix}").write_text(mesh_text)
    text = RING_TEXT.replace('[objects.shape]\nkind = "ring"', f'mesh = "m{suffix}"\n[objects.unused]\nkind = "ring"')
    text = text[:text.index("[objects.unused]")] + text[text.index("[photons]"):]
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("mesh, match", [
    ("", r"has no triangles"),
    ("v 0 0 0\nv 1 0 0\nv nan 0 1\nf 1 2 3\n", r"has NaN or infinite vertex coordinates \(1 vertices, "
                                             r"the first is vertex 3\); fix the mesh"),
])
def test_empty_and_nan_meshes_are_errors(tmp_path, mesh, match):
    path = _mesh_scene(tmp_path, mesh)
    with pytest.raises(InputError, match=r"scene\.toml: objects\[1\]\.mesh: .*(" + match + ")"):
        load_scene(path)


def test_non_manifold_mirror_mesh_loads_and_traces(tmp_path):
    # Three triangles sharing one edge (non-manifold) and an open fan: the renderer only
    # needs triangles, so this is accepted, and photons bounce off it.
    mesh = ("v -0.5 0 0\nv 0.5 0 0\nv 0 0.4 0.3\nv 0 0.4 -0.3\nv 0 -0.4 0.3\n"
            "f 1 2 3\nf 2 1 4\nf 1 2 5\n")
    scene = load_scene(_mesh_scene(tmp_path, mesh))
    ring = [o for o in scene.objects if o.name == "ring"][0]
    assert len(ring.mesh.faces) == 3
    assert not trimesh.Trimesh(ring.mesh.vertices, ring.mesh.faces, process=False).is_watertight


KEYS = ["[camera]", "eye", "target", "fov_y_deg", "width", "[materials.floor]", "kd", "reflectance",
        "[[lights]]", "position", "power", "[[objects]]", "inner_radius", "segments", "[photons]",
        "count", "seed"]
VALUES = st.one_of(st.integers(-10**12, 10**12), st.floats(allow_nan=True, allow_infinity=True),
                   st.text(max_size=5), st.booleans(), st.lists(st.floats(-1e3, 1e3), max_size=4))


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return {"nan": "nan", "inf": "inf", "-inf": "-inf"}.get(repr(v), repr(v))
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"').replace("\n", " ") + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return str(v)


@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(key=st.sampled_from(KEYS), value=VALUES, drop=st.booleans())
def test_fuzzed_scene_files_load_or_name_the_file(key, value, drop):
    lines = RING_TEXT.splitlines()
    hits = [i for i, line in enumerate(lines) if line.split("=")[0].strip() == key or line.strip() == key]
    i = hits[0]
    if drop:
        del lines[i]
    elif "=" in lines[i]:
        lines[i] = f"{key} = {_toml_value(value)}"
    else:
        lines[i] = f"{key} = {_toml_value(value)}"  # a table header turned into a key
    try:
        parse_scene("\n".join(lines), path=RING)
    except InputError as exc:
        message = str(exc)
        assert message.startswith(str(RING) + ":")
        assert "\n" not in message.strip()


@settings(max_examples=30, deadline=None)
@given(st.binary(max_size=200))
def test_random_bytes_as_a_scene_file_are_an_input_error(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("fuzz") / "scene.toml"
    path.write_bytes(data)
    with pytest.raises(InputError, match=r"scene\.toml: "):
        load_scene(path)


def test_info_states_the_lookup_shader_limits(capsys):
    from conftest import context_or_skip

    context_or_skip("egl")
    assert main(["info", "--backend", "egl"]) == 0
    out = capsys.readouterr().out
    assert "lookup MAX_K" in out and "128" in out and "lookup loop limit" in out
