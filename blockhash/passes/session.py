"""Frames rendered one state at a time: :class:`FrameSession` keeps a render's setup between
frames and builds again only what the new state moved.

A state is a :class:`~blockhash.scene.model.Scene`: the camera, the lights and the objects
where they are for that frame (an animation's :meth:`~blockhash.scene.animation.Animation.
scene_at`, or a scene a caller changed with :func:`dataclasses.replace`).  Against the last
frame's, each state is one of:

* **the camera alone** moved (or nothing): the photons are view-independent, so the frame
  gathers the passes' photons, indices and radii kept from the last frame
  (:class:`FrameCache`), and each pass's gather of every photon (for the points seen in
  mirrors), with the last frame's geometry, emitters and materials; it costs the camera's
  samples, the pixel splat, the splat's remainder's gather, the estimates and the direct light;
* **a light** moved (the objects where they were): the geometry (embree's and the device's
  scene), the materials and the compiled kernels are kept; the emitter (projection maps, light
  targets) and the indirect photons' pilot are built again and the photons traced from the
  same streams (common random numbers: the emitter keeps each photon's place where the light's
  change does not move it, :meth:`blockhash.photons.emission.Emitter._stable_cells`);
* **an object** moved: the device's acceleration structure is updated in place (the moved
  meshes' vertices, :meth:`blockhash.device.geometry.DeviceGeometry.move`); embree's host
  scene, which embreex cannot update, is built again.

Every frame uses the render's one seed: a frame is the still render of its state at that seed,
bit for bit, whichever way its setup was reached.  Frames of a plan whose executor is not in
this process (local workers, a Dask cluster) build their setup in the workers, every frame.
"""

from __future__ import annotations

import copy
import dataclasses
import time

import numpy as np

from blockhash.errors import NonFiniteError

#: The most bytes of photons, indices and radii kept for the frames of a camera-only
#: animation (estimated per pass from its arrays); passes past it are traced every frame.
CACHE_BYTES = 2 << 30


#: What a frame's state moved, against the last frame's (:meth:`FrameSession.frame`).
FIRST, CAMERA, LIGHTS, OBJECTS = "first", "camera", "lights", "objects"


class FrameSession:
    """Frames of ``scene`` (the first state) rendered one state at a time (module docstring).
    The keywords are :func:`blockhash.passes.pipeline.render`'s, for every frame.

    >>> session = FrameSession(scene, photons=200_000, plan=RenderPlan(passes=1))
    >>> first = session.frame()                  # the scene as given
    >>> moved = session.frame(camera=replace(scene.camera, eye=eye))   # the last state, moved
    >>> other = session.frame(another_scene)     # a whole state

    ``seconds`` and ``moved`` list each frame's seconds and what it moved (:data:`FIRST`,
    :data:`CAMERA`, :data:`LIGHTS`, :data:`OBJECTS`); ``last`` is the last frame's
    :class:`~blockhash.passes.renderer.Renderer` (its passes, timings and notes).
    """

    def __init__(self, scene, *, photons=None, spp=None, seed=None, estimate=None, lookup=None,
                 backend=None, plan=None):
        from blockhash.frame.estimate import EstimateOptions
        from blockhash.frame.options import LookupOptions
        from blockhash.passes.plan import RenderPlan

        self.scene = scene
        self.plan = plan or RenderPlan()
        self._keywords = dict(photons=photons, spp=spp, seed=seed,
                              estimate=estimate or EstimateOptions(),
                              lookup=lookup or LookupOptions(), backend=backend)
        self._setup = None
        self._state = scene
        self.last = None
        self.seconds: list[float] = []
        self.moved: list[str] = []

    @property
    def frames_per_second(self) -> float:
        """Frames a second over the frames after the first (their median seconds); nan
        before a second frame."""
        return 1.0 / float(np.median(self.seconds[1:])) if len(self.seconds) > 1 else float("nan")

    def frame(self, scene=None, *, camera=None, lights=None, objects=None,
              number: int | None = None):
        """The :class:`~blockhash.frame.result.RenderResult` of state ``scene`` (None: the last
        frame's state, the session's first scene before any), with ``camera``, ``lights`` (a
        sequence of the scene's lights) and ``objects`` (of its objects) where given; its setup
        reached from the last frame's.  ``number`` names the frame in errors (default: its
        place among the session's frames)."""
        from blockhash.passes.executors import InProcess
        from blockhash.passes.pipeline import make_renderer
        from blockhash.passes.run import run_passes

        t = time.perf_counter()
        scene = self._state if scene is None else scene
        given = {k: v for k, v in (("camera", camera), ("lights", lights), ("objects", objects))
                 if v is not None}
        if given:
            scene = dataclasses.replace(scene, **{k: v if k == "camera" else tuple(v)
                                                  for k, v in given.items()})
        self._state = scene
        renderer, plan = make_renderer(scene, plan=self.plan, **self._keywords)
        moved = FIRST
        if isinstance(plan.executor, InProcess):
            renderer._setup, moved = self._setup_for(scene, renderer)
        try:
            run_passes(renderer, plan)
        except NonFiniteError as exc:
            raise NonFiniteError(f"frame {len(self.seconds) if number is None else number}, "
                                 f"{exc}") from exc
        self.last = renderer
        self.moved.append(moved)
        self.seconds.append(time.perf_counter() - t)
        return renderer.image

    def _setup_for(self, scene, renderer):
        """(the frame's :class:`~blockhash.passes.task.RenderSetup`, what it moved)."""
        from blockhash.passes.task import RenderSetup

        last = self._setup
        if last is None or last.settings != renderer.settings or last.traced is not None:
            setup, moved = renderer.setup, FIRST
        else:
            moved = what_moved(last.scene, scene)
            if moved == CAMERA:
                self._setup = with_scene(last, scene)
                return self._setup, moved
            setup = RenderSetup(scene, renderer.settings, kept=last, objects_moved=moved == OBJECTS)
        setup.cache = FrameCache(CACHE_BYTES)
        self._setup = setup
        return setup, moved


def what_moved(before, after) -> str:
    """:data:`OBJECTS` when an object of ``after`` is not ``before``'s (its mesh, material or
    name; or another count of them), else :data:`LIGHTS` when a light is not, else
    :data:`CAMERA` (the camera, or nothing, moved).  Anything else the two scenes hold (the
    photon settings, the bounds) is :data:`OBJECTS`: everything built again."""
    if len(before.objects) != len(after.objects) or not all(
            same(a, b) for a, b in zip(before.objects, after.objects)):
        return OBJECTS
    rest = {"camera", "lights", "objects", "animation", "path", "description"}
    if not all(same(getattr(before, f.name), getattr(after, f.name))
               for f in dataclasses.fields(before) if f.name not in rest):
        return OBJECTS
    if len(before.lights) != len(after.lights) or not all(
            same(a, b) for a, b in zip(before.lights, after.lights)):
        return LIGHTS
    return CAMERA


def same(a, b) -> bool:
    """``a`` and ``b`` hold the same values: arrays equal, dataclasses field by field,
    meshes by their vertices and faces (an object is the same object first)."""
    if a is b:
        return True
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.shape(a) == np.shape(b) and bool(np.array_equal(a, b))
    if type(a) is not type(b):
        return False
    if dataclasses.is_dataclass(a):
        return all(same(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a))
    if hasattr(a, "vertices") and hasattr(a, "faces"):
        return same(np.asarray(a.vertices), np.asarray(b.vertices)) and \
            same(np.asarray(a.faces), np.asarray(b.faces))
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return bool(a == b)


def with_scene(setup, scene):
    """``setup`` for another frame whose camera alone moved: the same geometry, emitters,
    materials, stages and kept passes, the frame's scene, camera and film (its size and pixel
    filter may differ from the last frame's)."""
    from blockhash.frame.film_filter import PassFilm
    from blockhash.scene.camera import Pinhole

    out = copy.copy(setup)
    out.scene, out.pin = scene, Pinhole.of(scene.camera)
    out.pixel_filter = PassFilm(out.pin, scene.camera.filter, setup.settings.grid)
    return out


class FrameCache(dict):
    """A pass's photons, index and radii by (map, pass), kept while their bytes stay under
    ``limit`` (:data:`CACHE_BYTES`); ``bytes`` what it holds."""

    def __init__(self, limit: int):
        super().__init__()
        self.limit, self.bytes = int(limit), 0

    def keep(self, key, value) -> None:
        size = _nbytes(value, set())
        if self.bytes + size <= self.limit:
            self[key] = value
            self.bytes += size


def _nbytes(value, seen: set, depth: int = 4) -> int:
    """Bytes of the arrays a kept value holds (a photon map, an index and what it holds, such
    as its records, radii), followed ``depth`` levels into objects, tuples and dicts, each
    array counted once (``seen``: the ids counted)."""
    if isinstance(value, np.ndarray):
        if id(value) in seen:
            return 0
        seen.add(id(value))
        return value.nbytes
    if depth == 0 or value is None or isinstance(value, (str, bytes, int, float)):
        return 0
    if isinstance(value, dict):
        items = value.values()
    elif isinstance(value, (tuple, list)):
        items = value
    else:
        items = vars(value).values() if hasattr(value, "__dict__") else ()
    return sum(_nbytes(v, seen, depth - 1) for v in items)
