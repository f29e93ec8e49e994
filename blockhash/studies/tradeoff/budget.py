"""Settings for a budget: pick N, k and A from a scene's measured trade study.

``blockhash render SCENE --time-budget S`` (or ``--target-error E``) reads the scene's
study (``tradeoff.json`` of ``blockhash tradeoff``, also kept in the cache by scene
content), or runs a short calibration study when there is none, and picks:

* with a time budget: the setting with the least error against the reference whose
  predicted time fits;
* with a target error: the fastest setting whose error is at most the target.

Predicted time = trace + index build + caustic pass, the pass scaled by the number of
shading points (the study's image is smaller than a render's).  Error is the study's
relative RMS against the light-traced reference after a 2-pixel blur, at the study's
image size.  Only the default preset and variant are chosen from (the others are for
comparison).  A scene with no specular object has no photon stages at all, so it needs
no choice (:func:`choose` says so).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from blockhash.errors import InputError
from blockhash.reference.lighttrace import scene_digest

ERROR_KEY = "rel_rms_reference_blur"
#: The calibration study run when a scene has none: three photon counts, four A values.
CALIBRATION = dict(photons=(10_000, 30_000, 100_000), grid_A=(2, 4, 8, 16), ks=(50,),
                   presets=("default",), preset_A=(8,), variants=("default",), size=(48, 48),
                   reference_photons=4_000_000, kdtree_shader=False)


@dataclass(frozen=True)
class Choice:
    photons: int
    k: int
    A: int
    predicted_seconds: float
    predicted_error: float
    reason: str

    def __repr__(self) -> str:
        return (f"Choice(photons={self.photons:,}, k={self.k}, A={self.A}, "
                f"predicted_seconds={self.predicted_seconds:.2f}, "
                f"predicted_error={self.predicted_error:.3f})")


def cache_path(scene, cache_dir) -> Path:
    """Where the study of ``scene`` is kept: by content, so an edited scene gets a new one."""
    return Path(cache_dir) / f"tradeoff-{scene_digest(scene)[:24]}.json"


def predicted_seconds(row, study, pixels: int) -> float:
    s = row["seconds"]
    w, h = study["size"]
    ss = study["plan"].get("supersample", 1)
    scale = pixels / float(w * h * ss * ss)
    return s["trace"] + s.get("index_build", 0.0) + s["caustic_pass"] * scale


def choose(study, *, pixels: int, time_budget=None, target_error=None) -> Choice:
    """The setting of ``study`` for a time budget (seconds) or a target error (one of the two)."""
    if (time_budget is None) == (target_error is None):
        raise InputError("give exactly one of time_budget (seconds) and target_error "
                         "(relative RMS against the reference)")
    rows = [r for r in study["rows"] if r["method"] == "bh" and r["preset"] == "default"
            and r["variant"] == "default" and r.get(ERROR_KEY) is not None]
    if not rows:
        raise InputError(f"the trade study of {study.get('scene')} has no default-preset rows; "
                         "rerun blockhash tradeoff")
    cands = [(predicted_seconds(r, study, pixels), r[ERROR_KEY], r) for r in rows]
    if time_budget is not None:
        if time_budget <= 0:
            raise InputError(f"time_budget={time_budget} must be positive seconds")
        fit = [c for c in cands if c[0] <= time_budget]
        if not fit:
            fastest = min(cands, key=lambda c: c[0])
            raise InputError(f"time_budget={time_budget:g} s: no measured setting fits; the fastest "
                             f"(N={fastest[2]['photons']:,}, A={fastest[2]['A']}) needs about "
                             f"{fastest[0]:.2f} s; raise the budget or render fewer pixels")
        t, e, r = min(fit, key=lambda c: (c[1], c[0]))
        why = (f"least error ({e:.3f}) among the {len(fit)} of {len(cands)} measured settings "
               f"predicted to fit {time_budget:g} s")
    else:
        if target_error <= 0:
            raise InputError(f"target_error={target_error} must be a positive relative RMS")
        fit = [c for c in cands if c[1] <= target_error]
        if not fit:
            best = min(cands, key=lambda c: c[1])
            raise InputError(f"target_error={target_error:g}: no measured setting reaches it; the "
                             f"best is {best[1]:.3f} (N={best[2]['photons']:,}, A={best[2]['A']}); "
                             "raise the target or run blockhash tradeoff with more photons")
        t, e, r = min(fit, key=lambda c: (c[0], c[1]))
        why = (f"fastest ({t:.2f} s predicted) of the {len(fit)} of {len(cands)} measured settings "
               f"with error <= {target_error:g}")
    return Choice(photons=r["photons"], k=r["k"], A=r["A"], predicted_seconds=t,
                  predicted_error=e, reason=why)


def study_for(scene, *, cache_dir, study_path=None, backend=None, progress=print) -> dict:
    """The scene's study: ``study_path``, else the cached one, else a calibration run (cached)."""
    if study_path is not None:
        path = Path(study_path)
        if not path.is_file():
            raise InputError.about("{study_path}{value}: no such file; give a tradeoff.json "
                                   "written by blockhash tradeoff", value=path)
        return json.loads(path.read_text())
    cached = cache_path(scene, cache_dir)
    if cached.is_file():
        progress(f"using the cached trade study {cached}")
        return json.loads(cached.read_text())
    from blockhash.studies.tradeoff.sweep import SweepPlan, run_sweep

    progress("no trade study of this scene yet: running a short calibration study")
    study = run_sweep(scene, SweepPlan(**CALIBRATION), cache_dir=cache_dir, backend=backend,
                      progress=progress)
    study.pop("_images", None)
    remember(study, scene, cache_dir)
    return study


def remember(study: dict, scene, cache_dir) -> Path:
    """Keep ``study`` (without images) in the cache under the scene's content hash."""
    path = cache_path(scene, cache_dir)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({k: v for k, v in study.items() if k != "_images"}, default=float))
    return path
