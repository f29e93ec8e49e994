"""Camera rays at glass follow both branches, each weighted by its Fresnel term."""

from pathlib import Path

import numpy as np
from scipy.ndimage import binary_erosion

from blockhash.frame.gbuffer import rasterize
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.passes.pipeline import render_scene
from blockhash.scene.loader import load_scene
from blockhash.scene.model import MirrorMaterial

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def test_the_branches_of_a_sample_carry_its_weight_to_what_they_shade():
    """Clear glass absorbs nothing: a sample's branches carry at most its whole weight, and
    only to surfaces that shade; branches that leave the scene are not kept."""
    scene = load_scene(SCENES / "glass.toml")
    g = rasterize(scene.camera, scene.objects, size=(48, 48))
    pts = shading_points(scene.camera, g, scene.objects, SceneRays(scene.objects),
                         (MirrorMaterial,), both_branches=True)
    assert pts.owner is not None and pts.samples == (48, 48)
    ball, floor = g.object == 1, g.object == 0
    assert ball.sum() > 50
    live = pts.material.reshape(-1) >= 0
    assert (~live).sum() < 48  # every point shades something but the last row's padding
    total = pts.gather(pts.weight.astype(np.float64))
    np.testing.assert_allclose(total[floor], 1.0, atol=1e-6)  # seen directly: one point
    assert (total[~ball & ~floor] == 0).all()  # the sky shades nothing
    # Through the ball most of the weight reaches the floor: at normal incidence
    # (1 - 0.04)^2 of it; what is reflected toward the sky is lost.
    assert (total[ball] <= 1.0 + 1e-6).all() and total[ball].mean() > 0.6
    assert (total[ball] > 0).mean() > 0.95
    split = np.bincount(pts.owner[live], minlength=48 * 48).reshape(48, 48)
    assert split[ball].max() >= 2  # some samples split into several points
    single = shading_points(scene.camera, g, scene.objects, SceneRays(scene.objects),
                            (MirrorMaterial,))
    assert single.owner is None and single.shape == (48, 48)


def test_the_ball_is_seen_without_speckle():
    """The direct layer inside the ball's silhouette at 4 samples per pixel is close to the
    same at 64 (4.4% at 40 x 40, the sub-pixel variation 4 samples leave); one random branch
    per sample was 17.7% here."""
    scene = load_scene(SCENES / "glass.toml")
    size = (40, 40)
    few = render_scene(scene, size=size, photons=20_000, spp=4)
    many = render_scene(scene, size=size, photons=20_000, spp=64)
    inner = binary_erosion(rasterize(scene.camera, scene.objects, size=size).object == 1)
    d = few.direct[inner] - many.direct[inner]
    rel = np.sqrt((d ** 2).mean()) / many.direct[inner].mean()
    assert rel < 0.08, f"relative RMS {rel:.3f} inside the ball"
    assert np.isfinite(few.caustic).all() and few.caustic.shape == (40, 40, 3)
