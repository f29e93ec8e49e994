"""Frames of animated scenes (blockhash.scene.animation, blockhash.passes.frames,
``blockhash render --frames``): each frame the still render of its scene, the photon work of a
camera-only animation shared, bad keys refused by name."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.cli import main
from blockhash.errors import InputError
from blockhash.passes.frames import frame_range, render_frames
from blockhash.passes.plan import RenderPlan
from blockhash.scene.loader import load_scene, parse_scene

pytestmark = pytest.mark.gl
SCENES = Path(__file__).resolve().parents[2] / "scenes"
RING = (SCENES / "ring.toml").read_text()
SIZE = (32, 32)
PHOTONS = 4000


def animated(extra: str):
    return parse_scene(RING + "\n" + extra, path=SCENES / "x.toml")


def frames_of(scene, frames, plan=RenderPlan(passes=2)):
    out = {}
    render_frames(scene.with_size(*SIZE) if scene.animation else scene, frames, photons=PHOTONS,
                  plan=plan, on_frame=lambda f, r, s: out.__setitem__(f, r.image))
    return out


def still(scene, frame, plan=RenderPlan(passes=2)):
    return blockhash.render(scene.animation.scene_at(scene.with_size(*SIZE), frame),
                            photons=PHOTONS, plan=plan)


def test_a_camera_orbits_frame_is_the_still_render_of_that_camera():
    """Frame 3 after frames 0..2 (gathering their photons, indices and radii) equals the still
    render of frame 3's camera with the same seed, float32 pixel for pixel."""
    scene = load_scene(SCENES / "ring_orbit.toml")
    assert not scene.animation.moves_photons
    got = frames_of(scene, range(4))
    for f in (0, 3):
        want = still(scene, f)
        for layer in ("direct", "caustic"):
            np.testing.assert_array_equal(getattr(got[f], layer), getattr(want, layer), err_msg=f"{f} {layer}")
    assert not np.array_equal(got[0].combined, got[3].combined)  # the camera moved
    eye0 = scene.animation.scene_at(scene, 0).camera.eye
    eye12 = scene.animation.scene_at(scene, 12).camera.eye
    target = scene.camera.target
    assert np.linalg.norm(eye12 - target) == pytest.approx(np.linalg.norm(eye0 - target))
    d = eye0 - target  # half a turn about +y through the target: (x, y, z) -> (-x, y, -z)
    np.testing.assert_allclose(scene.animation.scene_at(scene, 24).camera.eye,
                               target + d * np.array([-1.0, 1.0, -1.0]), atol=1e-9)


def test_a_moving_lights_frames_are_still_renders_of_each_frame():
    """Each frame of the light circling the ring is the still render of that frame's scene
    (the same seed: the photons of every frame come from the same streams); the keys are
    interpolated between frames."""
    scene = load_scene(SCENES / "ring_sweep.toml")
    assert scene.animation.moves_photons
    got = frames_of(scene, [3, 4])
    for f in (3, 4):
        want = still(scene, f)
        np.testing.assert_array_equal(got[f].caustic, want.caustic)
        np.testing.assert_array_equal(got[f].direct, want.direct)
    a, b = (scene.animation.scene_at(scene, f).lights[0].position for f in (3, 6))
    np.testing.assert_allclose(scene.animation.scene_at(scene, 4).lights[0].position,
                               a + (b - a) / 3, atol=1e-12)


def test_frames_are_identical_when_nothing_moves():
    scene = animated("[animation]\nframes = 3\n[[animation.camera]]\nframe = 0\nfov_y_deg = 38.0\n")
    got = frames_of(scene, range(3))
    np.testing.assert_array_equal(got[0].combined, got[1].combined)
    np.testing.assert_array_equal(got[1].combined, got[2].combined)


def test_frames_on_local_workers_equal_the_in_process_frames():
    for name in ("ring_orbit", "ring_sweep"):
        scene = load_scene(SCENES / f"{name}.toml")
        here = frames_of(scene, [5])
        there = frames_of(scene, [5], plan=RenderPlan(passes=2, executor=blockhash.LocalWorkers(2)))
        np.testing.assert_array_equal(here[5].combined, there[5].combined)


def test_the_command_writes_numbered_frames_and_a_video(tmp_path, capsys):
    import re

    import imageio.v2 as imageio

    out = tmp_path / "orbit.exr"
    assert main(["render", str(SCENES / "ring_orbit.toml"), "--frames", "2:5", "--size", "32x32",
                 "--photons", "3000", "--passes", "1", "-o", str(out)]) == 0
    summary = capsys.readouterr().out
    later, fps = re.search(r"median of the rest ([0-9.]+) \(([0-9.]+) frames a second", summary).groups()
    later, fps = float(later), float(fps)  # each rounded to 0.01
    assert 1.0 / (later + 0.005) - 0.005 <= fps <= 1.0 / max(later - 0.005, 1e-9) + 0.005
    for f in (2, 3, 4):
        assert (tmp_path / f"orbit-{f:04d}.exr").is_file() and (tmp_path / f"orbit-{f:04d}.png").is_file()
    assert not (tmp_path / "orbit-0001.exr").exists() and not (tmp_path / "orbit-0005.exr").exists()
    video = imageio.mimread(str(tmp_path / "orbit.mp4"))
    assert len(video) == 3 and video[0].shape[:2] == (32, 32)
    assert np.mean(video[0]) > 5  # lit, not black


def test_ctrl_c_keeps_the_frames_done(tmp_path):
    """SIGINT after the first frame's files: the frames done stay, with their video, exit 130."""
    code = (
        "import sys, os, signal\n"
        "from blockhash.cli import frames as F\n"
        "real = F.FrameWriter.add\n"
        "def add(self, frame, result):\n"
        "    real(self, frame, result)\n"
        "    if frame == 1: os.kill(os.getpid(), signal.SIGINT)\n"
        "F.FrameWriter.add = add\n"
        "from blockhash.cli import main\n"
        f"sys.exit(main(['render', {str(SCENES / 'ring_sweep.toml')!r}, '--frames', '0:6', "
        f"'--size', '24x24', '--photons', '2000', '--passes', '1', '-o', {str(tmp_path / 's.exr')!r}]))\n")
    # SIGINT as a terminal leaves it (a test process may have inherited it ignored, which
    # Python's own handler then is not installed over)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"},
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert run.returncode == 130, run.stderr[-2000:]
    assert "kept 2 frame(s)" in run.stderr
    assert sorted(p.name for p in tmp_path.glob("s-*.exr")) == ["s-0000.exr", "s-0001.exr"]
    assert (tmp_path / "s.mp4").is_file()


@pytest.mark.parametrize("extra, match", [
    ("[animation]\nframes = 4\n[[animation.camera]]\nframe = 4\neye = [0.0, 1.0, 1.0]\n",
     r"animation\.camera\[0\]\.frame: expected an integer in 0 .. 3; got 4"),
    ("[animation]\nframes = 8\n[[animation.camera]]\nframe = 5\neye = [0.0, 1.0, 1.0]\n"
     "[[animation.camera]]\nframe = 2\neye = [0.0, 2.0, 1.0]\n",
     r"animation\.camera\[1\]\.frame: frame 2 after a key at frame 5: .*increasing frame order"),
    ("[animation]\nframes = 8\n[[animation.lights]]\nlight = 3\nframe = 0\nposition = [0.0, 1.0, 0.0]\n",
     r"animation\.lights\[0\]\.light: light 3: the scene has 1 light\(s\), 0 .. 0"),
    ("[animation]\nframes = 8\n[[animation.objects]]\nobject = \"rign\"\nframe = 0\ntranslate = [0.0, 1.0, 0.0]\n",
     r"animation\.objects\[0\]\.object: unknown object 'rign'; the scene's objects: floor, ring"),
    ("[animation]\nframes = 8\n[[animation.objects]]\nobject = \"ring\"\nframe = 0\nscale = 2.0\n",
     r"animation\.objects\[0\]\.scale: an object's motion is rigid"),
    ("[animation]\nframes = 8\n[[animation.lights]]\nlight = 0\nframe = 0\ncone_deg = 20.0\n",
     r"animation\.lights\[0\]\.cone_deg: not animated here; allowed: position, power"),
    ("[animation]\nframes = 8\n[animation.orbit]\nturns = 1.0\n[[animation.camera]]\nframe = 0\n"
     "eye = [0.0, 1.0, 1.0]\n", r"animation\.orbit: an orbit and \[\[animation\.camera\]\] keys"),
    ("[animation]\nframes = 0\n", r"animation\.frames: expected an integer in 1 .. 100,000; got 0"),
    ("[animation]\nframes = 4\nfsp = 24\n", r"animation\.fsp: unknown key; allowed keys here: frames, fps"),
    ("[animation]\nframes = 4\n[[animation.camera]]\nframe = 3\nup = [0.0, 0.0, 1.0]\n"
     "target = [0.0, 1.9, 1.6]\n", r"animation: frame 0: .*target .* equals eye"),
])
def test_bad_keys_name_the_key_and_the_way_out(extra, match):
    with pytest.raises(InputError, match=r"^scenes/x\.toml: " + match):
        parse_scene(RING + "\n" + extra, path="scenes/x.toml")


def test_an_area_light_moves_with_its_object_and_cannot_be_keyed_itself():
    cbox = (SCENES / "cbox.toml").read_text()
    with pytest.raises(InputError, match=r"animation\.lights\[0\]\.light: light 0 is an area light "
                                         r"on object 'light': animate that object instead"):
        parse_scene(cbox + "\n[animation]\nframes = 4\n[[animation.lights]]\nlight = 0\nframe = 0\n"
                    "position = [0.0, 1.0, 0.0]\n", path="scenes/x.toml")
    scene = parse_scene(cbox + "\n[animation]\nframes = 4\n[[animation.objects]]\nobject = \"light\"\n"
                        "frame = 3\ntranslate = [0.3, 0.0, 0.0]\n", path="scenes/x.toml")
    moved = scene.animation.scene_at(scene, 3)
    lamp = next(o for o in moved.objects if o.name == "light")
    assert moved.lights[0].mesh is lamp.mesh  # the light is the moved object's surface
    np.testing.assert_allclose(moved.lights[0].triangles.mean(axis=(0, 1)),
                               scene.lights[0].triangles.mean(axis=(0, 1)) + [0.3, 0, 0], atol=1e-12)


def test_the_summary_names_the_frames_and_what_moves():
    assert load_scene(SCENES / "ring_sweep.toml").summary().splitlines()[-1] == \
        "  frames  48 at 24 fps; keyed: light 0"
    assert load_scene(SCENES / "ring_orbit.toml").summary().endswith("keyed: camera orbit")


def test_frame_ranges_and_a_still_refused():
    assert frame_range(None, 5) == range(5) and frame_range("1:3", 5) == range(1, 3)
    assert frame_range(":2", 5) == range(2) and frame_range("4", 5) == range(4, 5)
    for bad in ("3:9", "x", "4:2"):
        with pytest.raises(InputError, match=rf"text='{bad}'"):
            frame_range(bad, 5)
    with pytest.raises(InputError, match="has no \\[animation\\] table"):
        render_frames(load_scene(SCENES / "ring.toml"), [0])


def test_the_frame_cache_counts_the_arrays_an_index_holds():
    """An index's records and order count toward the cache's limit (they are most of its
    bytes), each array once (the radii and the radii object holding them), and a value past
    the limit is not kept."""
    from blockhash.index.block_hash_index import BlockHashIndex
    from blockhash.passes.schedule import FixedRadii
    from blockhash.passes.session import FrameCache

    index = BlockHashIndex(np.random.default_rng(0).random((10_000, 3)).astype(np.float32),
                           tables=False)
    r2 = np.ones(10_000)
    held = index.records.records.nbytes + index.order.nbytes + r2.nbytes
    cache = FrameCache(limit=10**9)
    cache.keep(("caustic", 0), (index, r2, FixedRadii(r2)))
    assert held <= cache.bytes < held + r2.nbytes
    small = FrameCache(limit=held - 1)
    small.keep(("caustic", 0), (index, r2, FixedRadii(r2)))
    assert ("caustic", 0) not in small and small.bytes == 0


def test_a_frame_whose_pass_has_a_nan_pixel_is_named(monkeypatch):
    from blockhash.errors import NonFiniteError
    from blockhash.passes import executors
    from blockhash.passes.task import run_pass

    def nan_pass(*args, **kw):
        c = run_pass(*args, **kw)
        c.direct[0, 0, 0] = np.inf
        return c

    monkeypatch.setattr(executors, "run_pass", nan_pass)
    scene = load_scene(SCENES / "ring_orbit.toml")
    with pytest.raises(NonFiniteError, match=r"frame 0, pass 0 \(rendered in this process\): "
                                             r"the direct layer has 1 non-finite pixel"):
        frames_of(scene, [0, 1])
