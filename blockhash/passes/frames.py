"""Frames of an animated scene (:mod:`blockhash.scene.animation`): each frame a render of
passes, what a frame shares with the last not done again.

* **Camera alone moving**: the photon map is view-independent, so every frame gathers the
  same photons.  The first frame's setup (embree geometry, emitters, materials, the indirect
  pilot) serves every frame, and each pass's photons, index and photon radii (both maps) are
  kept after the first frame and gathered by every later one (:attr:`RenderSetup.cache
  <blockhash.passes.task.RenderSetup.cache>`): a frame then costs the camera's samples, the
  pixel splat, the gathers and the direct light.  The kept passes are bounded by
  :data:`CACHE_BYTES`; passes beyond it are traced again in every frame (the same photons:
  the streams are the pass's).
* **A light or an object moving**: every frame traces its photons again, from the same
  streams and seed (common random numbers), so a photon's path moves with the light and the
  caustic's noise moves with the caustic instead of flickering from frame to frame.  The
  frame's setup is built for its scene (the GL context and programs are the process's).

Every frame uses the render's one seed, and a frame's image is a function of its scene and
the settings: the same bit for bit whichever executor ran its passes.
"""

from __future__ import annotations

import copy
import time

import numpy as np

from blockhash.errors import InputError, NonFiniteError

#: The most bytes of photons, indices and radii kept for the frames of a camera-only
#: animation (estimated per pass from its arrays); passes past it are traced every frame.
CACHE_BYTES = 2 << 30


def frame_range(text: str | None, frames: int) -> range:
    """The frames ``text`` names: None or '' all, ``A:B`` frames A .. B - 1 (either side may
    be left out), ``N`` frame N alone."""
    if not text:
        return range(frames)
    try:
        if ":" in text:
            a, b = text.split(":", 1)
            r = range(int(a) if a.strip() else 0, int(b) if b.strip() else frames)
        else:
            r = range(int(text), int(text) + 1)
    except ValueError:
        raise InputError.about("{text}{value!r}: expected N, A:B or nothing (all frames)",
                               value=text) from None
    if not len(r) or r.start < 0 or r.stop > frames:
        raise InputError.about("{text}{value!r}: the animation has frames 0 .. {last}; give a "
                               "range within them, e.g. 0:{frames}", value=text, last=frames - 1,
                               frames=frames)
    return r


def with_scene(setup, scene):
    """``setup`` for another frame of a camera-only animation: the same geometry, emitters,
    materials, stages and kept passes, the frame's scene and camera."""
    from blockhash.scene.camera import Pinhole

    out = copy.copy(setup)
    out.scene, out.pin = scene, Pinhole.of(scene.camera)
    return out


def render_frames(scene, frames, *, photons=None, spp=None, seed=None, estimate=None,
                  lookup=None, backend=None, plan=None, on_frame=None):
    """Render ``frames`` (an iterable of frame numbers) of ``scene``'s animation; calls
    ``on_frame(frame, renderer, seconds)`` after each and returns ``{frame: seconds}``.  The
    other parameters are :func:`blockhash.passes.pipeline.render`'s, for every frame."""
    from blockhash.frame.estimate import EstimateOptions
    from blockhash.frame.options import LookupOptions
    from blockhash.passes.executors import InProcess
    from blockhash.passes.pipeline import make_renderer
    from blockhash.passes.plan import RenderPlan
    from blockhash.passes.run import run_passes

    anim = scene.animation
    if anim is None:
        raise InputError(f"{scene.path or 'the scene'} has no [animation] table: frames need "
                         "keyframes (blockhash/scene/animation.py); render it as a still")
    plan = plan or RenderPlan()
    share = not anim.moves_photons and isinstance(plan.executor, InProcess)
    base = None
    seconds = {}
    for f in frames:
        t = time.perf_counter()
        scene_f = anim.scene_at(scene, f)
        renderer, plan_f = make_renderer(scene_f, photons=photons, spp=spp, seed=seed,
                                         estimate=estimate or EstimateOptions(),
                                         lookup=lookup or LookupOptions(), backend=backend,
                                         plan=plan)
        if share:
            if base is None:
                base = renderer.setup
                base.cache = FrameCache(CACHE_BYTES)
            else:
                renderer._setup = with_scene(base, scene_f)
        try:
            run_passes(renderer, plan_f)
        except NonFiniteError as exc:
            raise NonFiniteError(f"frame {f}, {exc}") from exc
        seconds[f] = time.perf_counter() - t
        if on_frame is not None:
            on_frame(f, renderer, seconds[f])
    return seconds


class FrameCache(dict):
    """A pass's photons, index and radii by (map, pass), kept while their bytes stay under
    ``limit`` (:data:`CACHE_BYTES`); ``bytes`` what it holds."""

    def __init__(self, limit: int):
        super().__init__()
        self.limit, self.bytes = int(limit), 0

    def keep(self, key, value) -> None:
        size = sum(_nbytes(v) for v in value)
        if self.bytes + size <= self.limit:
            self[key] = value
            self.bytes += size


def _nbytes(value, depth: int = 3) -> int:
    """Bytes of the arrays a kept value holds (a photon map, an index and what it holds, such
    as its records, radii), followed ``depth`` levels into objects, tuples and dicts."""
    if isinstance(value, np.ndarray):
        return value.nbytes
    if depth == 0 or value is None or isinstance(value, (str, bytes, int, float)):
        return 0
    if isinstance(value, dict):
        items = value.values()
    elif isinstance(value, (tuple, list)):
        items = value
    else:
        items = vars(value).values() if hasattr(value, "__dict__") else ()
    return sum(_nbytes(v, depth - 1) for v in items)
