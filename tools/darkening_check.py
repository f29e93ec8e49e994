"""Darkening per A, and whether a gain fitted on one scene lowers the error on another.

Reads two trade studies written by ``blockhash tradeoff`` (``tradeoff.json`` and
``images.exr``: the caustic layer at A = 1, 2, 4, 8, 16 at the study's largest N and
base k, and the reference).  For each A the gain g_A = sum(reference) / sum(BH image)
is fitted on the first study's scene and applied to the second's images; the table
gives the second scene's flux ratio and blurred relative RMS against its reference
without and with the gain, so a correction counts only where it helps a scene it was
not fitted on.  The compared pixels are recomputed from the cached reference (its
``comparison_mask``: pixels seen through a mirror or glass are left out, because the light
tracer cannot connect a caustic to the pinhole through a delta surface).

    python tools/darkening_check.py docs/tradeoff/ring docs/tradeoff/venus
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blockhash.evaluate.images import read_layers
from blockhash.reference.lighttrace import cached_reference, lambertian
from blockhash.scene.loader import load_scene
from blockhash.studies.command import ToolParser
from blockhash.studies.density.estimates import reference_options
from blockhash.studies.measure import errors_against


def load(study_dir: Path, cache, scene_path):
    """(the study, its layers, the comparison mask of its reference); ``scene_path`` resolves
    the study's scene (a path, a checkout path or a name under scenes/)."""
    study = json.loads((study_dir / "tradeoff.json").read_text())
    layers = read_layers(study_dir / "images.exr")
    scene = load_scene(scene_path(study["scene"]))
    if scene.objects and study.get("lambertian"):
        scene = lambertian(scene)
    ref, _ = cached_reference(scene, study["reference"]["photons"], size=tuple(study["size"]),
                              cache_dir=cache)
    return study, layers, ref.comparison_mask()


def main(argv=None) -> None:
    p = ToolParser(__doc__, __file__)
    p.add_argument("fit", type=Path, help="study directory the gains are fitted on")
    p.add_argument("test", type=Path, help="study directory they are tested on")
    reference_options(p)
    args = p.parse_args(argv)
    fit, fit_img, fit_mask = load(args.fit, args.cache, p.scene)
    test, test_img, test_mask = load(args.test, args.cache, p.scene)
    print(f"gains fitted on {fit['scene']}, tested on {test['scene']} "
          f"(N = {max(test['plan']['photons']):,}, k = {test['plan']['k0']})")
    print(f"{'A':>3} {'gain':>7} {'flux before':>12} {'flux after':>11} {'RMS blur before':>16} "
          f"{'RMS blur after':>15}")
    for key in sorted((k for k in test_img if k.startswith("A") and k in fit_img), key=lambda k: int(k[1:])):
        gain = float(fit_img["reference"][fit_mask].sum() / fit_img[key][fit_mask].sum())
        img, ref = test_img[key].astype(np.float64), test_img["reference"].astype(np.float64)
        before = errors_against(img, ref, test_mask, "ref")
        after = errors_against(img * gain, ref, test_mask, "ref")
        print(f"{key[1:]:>3} {gain:>7.3f} {before['flux_ratio_ref']:>12.3f} {after['flux_ratio_ref']:>11.3f} "
              f"{before['rel_rms_ref_blur']:>16.3f} {after['rel_rms_ref_blur']:>15.3f}")


if __name__ == "__main__":
    main()
