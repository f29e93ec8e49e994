"""Frames of an animated scene (:mod:`blockhash.scene.animation`): each frame a render of
passes, what a frame shares with the last not done again (each frame's state handed to a
:class:`~blockhash.passes.session.FrameSession`, which keeps the setup between frames).

* **Camera alone moving**: the photon map is view-independent, so every frame gathers the
  same photons.  The first frame's setup (embree geometry, emitters, materials, the indirect
  pilot) serves every frame, and each pass's photons, index and photon radii (both maps) are
  kept after the first frame and gathered by every later one (:attr:`RenderSetup.cache
  <blockhash.passes.task.RenderSetup.cache>`): a frame then costs the camera's samples, the
  pixel splat, the gathers and the direct light.  The kept passes are bounded by
  :data:`~blockhash.passes.session.CACHE_BYTES`; passes beyond it are traced again in every frame (the same photons:
  the streams are the pass's).
* **A light or an object moving**: every frame traces its photons again, from the same
  streams and seed (common random numbers), so a photon's path moves with the light and the
  caustic's noise moves with the caustic instead of flickering from frame to frame.  A frame
  whose lights alone moved keeps the last frame's geometry and materials and builds its
  emitter again; one whose objects moved updates the device's acceleration structure
  (:mod:`.session`).

Every frame uses the render's one seed, and a frame's image is a function of its scene and
the settings: the same bit for bit whichever executor ran its passes.
"""

from __future__ import annotations

from blockhash.errors import InputError


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


def render_frames(scene, frames, *, photons=None, spp=None, seed=None, estimate=None,
                  lookup=None, backend=None, plan=None, on_frame=None):
    """Render ``frames`` (an iterable of frame numbers) of ``scene``'s animation, each frame's
    state handed to one :class:`~blockhash.passes.session.FrameSession`; calls
    ``on_frame(frame, renderer, seconds)`` after each and returns ``{frame: seconds}``.  The
    other parameters are :func:`blockhash.passes.pipeline.render`'s, for every frame."""
    from blockhash.passes.session import FrameSession

    anim = scene.animation
    if anim is None:
        raise InputError(f"{scene.path or 'the scene'} has no [animation] table: frames need "
                         "keyframes (blockhash/scene/animation.py); render it as a still")
    session = FrameSession(scene, photons=photons, spp=spp, seed=seed, estimate=estimate,
                           lookup=lookup, backend=backend, plan=plan)
    seconds = {}
    for f in frames:
        session.frame(anim.scene_at(scene, f), number=f)
        seconds[f] = session.seconds[-1]
        if on_frame is not None:
            on_frame(f, session.last, seconds[f])
    return seconds
