"""The render in passes (blockhash.passes.renderer, film, stopping): convergence on an
analytic plane, one pass equal to the single render, reproducibility, stopping rules, Ctrl-C
and memory."""

import gc
import math
import warnings
import weakref

import numpy as np
import pytest
import trimesh

import blockhash
from blockhash.errors import InputError
from blockhash.frame.subpixel import pass_offsets
from blockhash.passes.film import Film
from blockhash.passes.pipeline import render, render_scene
from blockhash.passes.renderer import EMPTY_PASSES_WARNING, EmptyPassesWarning, Renderer
from blockhash.passes.run import run_passes
from blockhash.passes.schedule import Schedule, shrink
from blockhash.passes.stopping import Passes, TargetOutOfReach
from blockhash.scene.model import (
    Camera,
    MirrorMaterial,
    PhongMaterial,
    PhotonSettings,
    PointLight,
    Scene,
    SceneObject,
)

KD, RHO, POWER = 0.6, 0.9, 40.0
#: Mirror at y = 0 (half sides MX x MZ) under a point light at height D; the caustic (the
#: light's mirror image through the mirror's rectangle) falls on a ceiling at height H.
MX, MZ, D, H = 0.4, 0.25, 1.0, 2.0
SIZE = 32


def _quad(y, hx, hz, normal):
    v = np.array([[-hx, y, -hz], [hx, y, -hz], [hx, y, hz], [-hx, y, hz]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    if np.cross(v[1] - v[0], v[2] - v[0]) @ normal < 0:
        f = f[:, ::-1]
    return trimesh.Trimesh(v, f, vertex_normals=np.tile(normal, (4, 1)), process=False)


@pytest.fixture(scope="module")
def plane():
    """The mirror, the ceiling and a camera under the ceiling looking up at the caustic."""
    ceiling = PhongMaterial(kd=np.full(3, KD), ks=np.zeros(3), n=1.0)
    mirror = MirrorMaterial(reflectance=np.full(3, RHO))
    objects = (SceneObject("mirror", _quad(0.0, MX, MZ, np.array([0.0, 1.0, 0.0])), mirror),
               SceneObject("ceiling", _quad(H, 3.0, 3.0, np.array([0.0, -1.0, 0.0])), ceiling))
    cam = Camera(eye=(0.0, 1.3, 0.0), target=(0.0, H, 0.0), up=(0.0, 0.0, -1.0), fov_y_deg=100.0,
                 width=SIZE, height=SIZE)
    return Scene(camera=cam, lights=(PointLight(position=(0.0, D, 0.0), power=(POWER,) * 3),),
                 objects=objects, photons=PhotonSettings(count=4000, k=50, A=8, seed=2,
                                                         max_bounces=2))


def analytic_caustic(scene, sub: int = 8) -> np.ndarray:
    """(h, w) pixel means of the caustic radiance on the ceiling: kd / pi * rho I cos / r^2
    from the light's mirror image, where its ray crosses the mirror; ``sub`` x ``sub`` points
    per pixel."""
    from blockhash.scene.camera import Pinhole

    pin = Pinhole.of(scene.camera)
    off = (np.arange(sub) + 0.5) / sub
    x = (np.arange(SIZE)[None, :, None, None] + off[None, None, None, :])
    y = (np.arange(SIZE)[:, None, None, None] + off[None, None, :, None])
    x, y = np.broadcast_arrays(x, y)
    d = pin.film_rays(x, y)
    t = (H - pin.eye[1]) / d[:, 1]
    p = pin.eye + t[:, None] * d
    v = p - np.array([0.0, -D, 0.0])
    r2 = np.sum(v * v, axis=1)
    cos = v[:, 1] / np.sqrt(r2)
    cross = v * (D / v[:, 1])[:, None] + np.array([0.0, -D, 0.0])
    inside = (np.abs(cross[:, 0]) <= MX) & (np.abs(cross[:, 2]) <= MZ)
    L = KD / np.pi * RHO * POWER / (4 * np.pi) * cos / r2 * inside
    return L.reshape(SIZE, SIZE, sub * sub).mean(axis=2)


def _error(img, truth):
    return float(np.sqrt(np.mean((img[..., 0] - truth) ** 2)) / np.sqrt(np.mean(truth ** 2)))


@pytest.mark.gl
def test_passes_converge_on_an_analytic_plane(plane):
    """The error against the analytic caustic falls with passes (radii shrink, samples and
    photons grow), and the flux converges."""
    truth = analytic_caustic(plane)
    r = Renderer(plane)
    errors, flux = {}, {}
    while r.passes < 24:
        r.step()
        if r.passes in (1, 4, 24):
            img = r.image.caustic
            errors[r.passes] = _error(img, truth)
            flux[r.passes] = float(img[..., 0].sum() / truth.sum())
    assert errors[1] > errors[4] > errors[24], errors
    assert errors[24] < 0.7 * errors[1], errors
    assert abs(flux[24] - 1) < 0.03, flux
    est = r.film.estimated_error()
    assert 0 < est < errors[24] * 1.5  # noise only: at most the measured error and its noise


@pytest.mark.gl
def test_a_one_pass_render_is_the_single_render(plane):
    a = render(plane, spp=4, passes=Passes(passes=1, schedule=Schedule(footprint=0)))
    b = render_scene(plane, spp=4)
    np.testing.assert_array_equal(a.caustic, b.caustic)
    np.testing.assert_array_equal(a.direct, b.direct)
    assert a.passes == 1 and a.spp == 4


@pytest.mark.gl
def test_renders_are_reproducible_per_seed_and_pass_count(plane):
    a = render(plane, passes=Passes(passes=3))
    b = render(plane, passes=Passes(passes=3))
    c = render(plane, seed=9, passes=Passes(passes=3))
    np.testing.assert_array_equal(a.caustic, b.caustic)
    np.testing.assert_array_equal(a.direct, b.direct)
    assert not np.array_equal(a.caustic, c.caustic)
    assert a.passes == 3 and a.spp == 3
    assert a.info["photons_emitted"] == b.info["photons_emitted"]


@pytest.mark.gl
def test_stopping_rules(plane):
    r = Renderer(plane)
    assert run_passes(r, Passes(passes=2)) == "2 passes" and r.passes == 2
    r = Renderer(plane)
    assert run_passes(r, Passes(passes=None, seconds=1e-9)).startswith("time limit")
    assert r.passes == 1
    r = Renderer(plane)
    why = run_passes(r, Passes(passes=50, target_error=0.5))
    assert why.startswith("estimated error") and r.film.estimated_error() <= 0.5
    assert r.passes < 50
    with pytest.raises(TargetOutOfReach, match="target_error=1e-06 cannot be reached within "
                                               "passes=5"):
        run_passes(Renderer(plane), Passes(passes=5, target_error=1e-6))


@pytest.mark.parametrize("kwargs, match", [
    ({"passes": 0}, "passes=0: a render runs at least one pass"),
    ({"passes": None, "seconds": 0}, "seconds=0: the time limit must be a positive"),
    ({"passes": None, "seconds": -1.0}, "seconds=-1.0: "),
    ({"target_error": 0}, "target_error=0: .* must be > 0"),
    ({"target_error": 0.1, "passes": 1}, "cannot be reached within passes=1"),
    ({"passes": None}, "no pass limit needs seconds= or target_error="),
])
def test_bad_stopping_rules_name_the_setting_and_the_way_out(kwargs, match):
    """In the library's terms (its keywords), never the command line's flags."""
    with pytest.raises(InputError, match=match) as caught:
        Passes(**kwargs)
    assert "--" not in str(caught.value)


@pytest.mark.parametrize("alpha", [0.0, 1.0, -0.5, 2.0])
def test_alpha_outside_0_1_is_refused(alpha):
    with pytest.raises(InputError, match=r"alpha=.* is outside \(0, 1\)"):
        Schedule(alpha=alpha)


def test_the_radii_shrink_by_knaus_and_zwicker():
    assert shrink(0, 0.7) == 1.0
    for i in range(1, 40):  # r_{i+1}^2 / r_i^2 = (i + alpha) / (i + 1), 1-based passes
        assert shrink(i, 0.7) / shrink(i - 1, 0.7) == pytest.approx((i + 0.7) / (i + 1))
    # the photons within a radius, n r^2 with n ~ passes: grow as n^alpha
    assert shrink(9999, 2 / 3) * 10000 == pytest.approx(10000 ** (2 / 3), rel=0.3)


def test_camera_samples_cover_each_pixel_evenly_over_passes():
    """64 passes put one sample in each cell of an 8 x 8 grid of the pixel about once: the
    R2 sequence's low discrepancy (random points leave ~37% of cells empty)."""
    u = np.stack([pass_offsets(5, 4, p, 1)[0] for p in range(64)])
    v = np.stack([pass_offsets(5, 4, p, 1)[1] for p in range(64)])
    assert ((u >= 0) & (u < 1) & (v >= 0) & (v < 1)).all()
    cells = (np.floor(u * 8) * 8 + np.floor(v * 8)).astype(int)
    for i in range(4):
        for j in range(5):
            hit = np.bincount(cells[:, i, j], minlength=64)
            assert (hit == 0).sum() <= 12, hit
    a, b = pass_offsets(5, 4, 3, 1), pass_offsets(5, 4, 3, 1)
    assert np.array_equal(a[0], b[0]) and not np.array_equal(a[0], pass_offsets(5, 4, 4, 1)[0])


def test_film_means_weigh_passes_by_emitted_photons_and_estimate_their_spread():
    rng = np.random.default_rng(0)
    film = Film(3, 2)
    xs, ws = [], []
    for _ in range(50):
        x = 2.0 + rng.normal(0, 0.5, (3, 2, 3))
        w = int(rng.integers(900, 1100))
        film.add(np.full((3, 2, 3), 0.5), x, w)
        xs.append(x)
        ws.append(w)
    xs, ws = np.array(xs), np.array(ws, float)
    np.testing.assert_allclose(film.caustic, np.tensordot(ws, xs, 1) / ws.sum(), rtol=1e-12)
    np.testing.assert_allclose(film.direct, 0.5)
    # the variance of the mean: about sigma^2 / n
    assert np.mean(film.caustic_variance) == pytest.approx(0.25 / 50, rel=0.15)
    assert film.estimated_error() == pytest.approx(math.sqrt(0.25 / 50) / 2.0, rel=0.15)
    with pytest.raises(InputError, match="does not fit the film"):
        film.add(np.zeros((2, 2, 3)), np.zeros((2, 2, 3)), 1)
    assert Film(2, 2).estimated_error() == math.inf


@pytest.mark.gl
def test_a_pass_that_stores_nothing_counts_and_many_warn(plane, monkeypatch):
    r = Renderer(plane)
    r.step()
    one = r.film.caustic.copy()
    empty = blockhash.photons.tracing.CausticPhotons.empty()
    emitted = r.emitted_per_pass

    def no_photons(count, **kw):
        return type(empty)(empty.positions, empty.directions, empty.normals, empty.powers,
                           count, {})
    monkeypatch.setattr(r.setup.source, "emit", no_photons)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(EMPTY_PASSES_WARNING):
            r.step()
    # the empty passes' emitted photons count: the caustic is diluted, not kept
    np.testing.assert_allclose(r.film.caustic, one * emitted / (emitted * (1 + EMPTY_PASSES_WARNING)),
                               rtol=1e-9)
    assert [w.category for w in caught] == [EmptyPassesWarning]


@pytest.mark.gl
def test_memory_is_one_pass(plane):
    """A pass's photons, index and gather go when the next pass comes: nothing of pass 1 is
    alive after pass 3."""
    r = Renderer(plane)
    r.step()
    first = weakref.ref(r.index)
    r.step()
    r.step()
    gc.collect()
    assert first() is None


@pytest.mark.gl
def test_each_pass_estimates_with_its_shrunk_radii(plane):
    from blockhash.frame.photon_radius import own_radii2

    r = Renderer(plane, schedule=Schedule(footprint=0.0))
    for _ in range(3):
        stats = r.step()
    assert stats.scale == pytest.approx(shrink(2, 2 / 3)) and r.radii.scale == stats.scale
    own = own_radii2(r.index, plane.photons.k)
    np.testing.assert_allclose(r.radii(r.index, plane.photons.k), own * stats.scale, rtol=1e-6)



@pytest.mark.gl
def test_photons_under_a_pixel_footprint_are_splatted_into_their_pixel_keeping_the_flux(plane):
    """At 8 x 8 pixels every caustic photon's disc is under a footprint: the splat takes those
    the camera sees (the gather keeps those outside the image) and the flux is the gather's."""
    small = plane.with_size(8, 8)
    splat = Renderer(small, schedule=Schedule(footprint=1.0))
    gather = Renderer(small, schedule=Schedule(footprint=0.0))
    splat.step()
    gather.step()
    gathered = np.isfinite(splat.radii(splat.index, 50))  # the splatted photons' radii: inf
    assert splat.timings.get("pixel splat", 0) > 0 and gathered.sum() < splat.stored / 2
    a, b = splat.image.caustic.sum(), gather.image.caustic.sum()
    assert a == pytest.approx(b, rel=0.05)
    truth = analytic_caustic(small.with_size(SIZE, SIZE))  # the flux over the same view
    assert a / 3 / 64 == pytest.approx(truth.mean(), rel=0.05)


RING = __import__("pathlib").Path(__file__).resolve().parents[2] / "scenes" / "ring.toml"


@pytest.mark.gl
def test_ctrl_c_writes_the_image_so_far_with_its_pass_count(tmp_path, monkeypatch, capsys):
    import blockhash.passes.executors as executors
    from blockhash.cli import main
    from blockhash.frame.images import read_attribute, read_layers

    real = executors.run_pass

    def run_pass(setup, p, emitted, **kw):
        if p == 2:
            raise KeyboardInterrupt
        return real(setup, p, emitted, **kw)
    monkeypatch.setattr(executors, "run_pass", run_pass)
    out = tmp_path / "ring.exr"
    code = main(["render", str(RING), "--size", "24x24", "--photons", "3000", "--passes", "9",
                 "-o", str(out)])
    assert code == 130
    assert "interrupted (Ctrl-C); wrote the image of 2 passes" in capsys.readouterr().err
    assert int(read_attribute(out, "blockhash:passes")) == 2
    assert read_layers(out)["caustic"].max() > 0 and out.with_suffix(".png").is_file()


@pytest.mark.gl
def test_the_render_command_runs_passes_to_its_rule(tmp_path, capsys, monkeypatch):
    from blockhash.cli import main
    from blockhash.frame import images
    from blockhash.frame.images import read_attribute

    written = []
    real_png = images.write_png
    monkeypatch.setattr(images, "write_png", lambda path, img: (written.append(path),
                                                                real_png(path, img)))
    out = tmp_path / "ring.exr"
    assert main(["render", str(RING), "--size", "24x24", "--photons", "3000", "--passes", "3",
                 "--preview-every", "0.001", "-o", str(out)]) == 0
    # a preview after each pass (each ends more than 1 ms after the last), then the final PNG
    assert written == [out.with_suffix(".png")] * 4
    text = capsys.readouterr().out
    assert "passes: 3 (3 passes)" in text and "relative standard error" in text
    assert int(read_attribute(out, "blockhash:passes")) == 3
    assert int(read_attribute(out, "blockhash:spp")) == 3
    for flags, match in ((["--passes", "0"], "--passes 0: a render runs at least one pass"),
                         (["--time", "0"], "--time 0.0: the time limit must be a positive"),
                         (["--alpha", "1"], r"--alpha 1.0 is outside \(0, 1\)"),
                         (["--target-error", "-1"], "--target-error -1.0: .* must be > 0"),
                         (["--passes", "3", "--target-error", "1e-9"],
                          "--target-error 1e-09 cannot be reached within --passes 3"),
                         (["--preview-every", "0"], "--preview-every 0.0: the PNG is rewritten")):
        code = main(["render", str(RING), "--size", "16x16", "--photons", "3000", *flags,
                     "-o", str(out)])
        assert code == 2
        assert __import__("re").search(match, capsys.readouterr().err), flags


@pytest.mark.parametrize("footprint", [-1.0, math.inf, math.nan, "1"])
def test_a_footprint_that_is_not_a_finite_number_above_0_is_refused(footprint):
    with pytest.raises(InputError, match="splatted into their pixel must be a finite number"):
        Schedule(footprint=footprint)
