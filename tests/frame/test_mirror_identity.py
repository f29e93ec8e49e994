"""The mirror identity on scenes/mirror.toml (and the glass slab's on scenes/glass_block.toml):
on a Lambertian receiver the radiance a render shows in a planar mirror of reflectance rho is
rho times the radiance of the same floor point seen directly, in the caustic layer (the
photon map's L S D S E paths, which no particle or path tracer renders) and in the direct
layer, within the render's own noise between seeds and the resampling's error
(blockhash/evaluate/specular_identity.py).  A wrong weight or shading point on the camera's
mirror branch breaks it."""

from pathlib import Path

import numpy as np
import pytest

import blockhash
from blockhash.evaluate.specular_identity import identity_check, specular_view_map
from blockhash.frame import shading

ROOT = Path(__file__).resolve().parents[2]
SMALL = dict(size=(128, 128), photons=200_000, spp=4, seeds=(1, 2, 3, 4, 5, 6))

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def mirror():
    return blockhash.load_scene(ROOT / "scenes" / "mirror.toml")


def _summary(report):
    return {n: (l["holds"], l["limits"], [(r["ratio"][0], r["rel_rms"]) for r in l["runs"]])
            for n, l in report["layers"].items()}


def test_the_mirror_shows_rho_times_the_floor_seen_directly(mirror):
    report = identity_check(mirror, **SMALL)
    assert report["pixels"] > 1000, report["pixels"]  # the wall's pixels that see the floor
    for name in ("caustic", "direct"):
        layer = report["layers"][name]
        assert layer["holds"], _summary(report)
        # the limits are tight enough to see a 10% error in the mirror's weight
        assert layer["limits"]["ratio"] < 0.1, layer["limits"]
        for run in layer["runs"]:
            assert run["bright_pixels"] > 50 and min(run["flux"]) > 0, run


def test_a_wrong_mirror_weight_breaks_the_identity(mirror, monkeypatch):
    tables = shading._surface_tables

    def wrong(objects, mirror_types, geometry):
        glass, mir, spec, refl, ior, tint = tables(objects, mirror_types, geometry)
        refl.reflectance = refl.reflectance * 0.8  # camera rays' reflectance 20% low
        return glass, mir, spec, refl, ior, tint

    monkeypatch.setattr(shading, "_surface_tables", wrong)
    report = identity_check(mirror, **SMALL)
    for name in ("caustic", "direct"):
        assert not report["layers"][name]["holds"], _summary(report)
        assert all(abs(r["ratio"][0] - 0.8) < 0.05 for r in report["layers"][name]["runs"])


def test_a_wrong_shading_point_breaks_the_identity(mirror, monkeypatch):
    follow = shading._follow

    def tilted(rays, pos, nrm, dirs, side):
        bent = dirs + np.array([0.03, 0.0, 0.0])  # the reflected ray 1.7 degrees off
        return follow(rays, pos, nrm, bent / np.linalg.norm(bent, axis=1, keepdims=True), side)

    monkeypatch.setattr(shading, "_follow", tilted)
    report = identity_check(mirror, **SMALL)
    assert not report["layers"]["caustic"]["holds"], _summary(report)


def test_the_view_map_keeps_only_pixels_that_see_the_same_point_in_both_views(mirror):
    view = specular_view_map(mirror, (64, 64))
    w, h = view.size
    from blockhash.frame.scene_rays import SceneRays
    from blockhash.scene.camera import Pinhole

    pin = Pinhole.of(mirror.camera, (64, 64))
    d = pin.pixel_rays()
    hit, _, _, obj, _ = SceneRays(mirror.objects).first_hit(
        np.broadcast_to(pin.eye, d.shape).copy(), d)
    wall = [o.name for o in mirror.objects].index("wall")
    assert set(obj[view.pixels]) == {wall}            # every kept pixel sees the wall first
    assert 0 < len(view.pixels) < (obj == wall).sum()  # and not the wall's pixels that see the ring
    assert np.all((view.film >= 0) & (view.film < [w, h]))


def test_the_identity_holds_on_the_progressive_render(mirror):
    """The render in passes: photons splatted into the pixels that see them directly still
    reach the mirror's pixels, which gather every photon.  A footprint of 4 pixels splats most
    of the floor's caustic photons at this size (with the mirror's pixels gathering only what
    the splat left, the ratio falls to about 0.02)."""
    from blockhash.passes.plan import RenderPlan
    from blockhash.passes.schedule import Schedule

    def progressive(scene, *, photons, size, spp, seed):
        return blockhash.render(scene.with_size(*size), photons=photons, seed=seed,
                                plan=RenderPlan(passes=4, schedule=Schedule(footprint=4.0)))

    report = identity_check(mirror, **SMALL, render=progressive)
    layer = report["layers"]["caustic"]
    assert layer["holds"], _summary(report)
    assert all(abs(r["ratio"][0] - 1) < layer["limits"]["ratio"] for r in layer["runs"])
