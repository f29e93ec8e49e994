"""The render as a sequence of passes (stochastic progressive photon mapping): a
:class:`Renderer` holds one render's settings, its :class:`~.film.Film` and the totals of the
passes merged so far; its passes run wherever an executor puts them (:mod:`.executors`,
:func:`.run.run_passes`), or one at a time in this process with :meth:`Renderer.step`.

A pass is :func:`.task.run_pass`: a function of the setup a process builds once, the settings
and the pass number, so the passes of a render are independent (their radii follow
:mod:`.schedule`, their photons and camera samples their own streams) except for the photons
emitted per pass, which pass 0 fixes.  :meth:`Renderer.merge` adds contributions to the film in
pass order, whatever order they end in: a render of passes 0..N-1 is the same image however it
was run.

Memory is one pass's: a pass's photons, index, gather and GL textures are released before the
next pass traces (the last pass's index stays on the image for callers that query it, when it
ran in this process).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.options import LookupOptions
from blockhash.frame.result import RenderResult
from blockhash.passes.film import Film
from blockhash.passes.schedule import Schedule, shrink
from blockhash.passes.task import PassContribution, PassSettings, RenderSetup, run_pass
from blockhash.photons.tracing import no_caustic_reason
from blockhash.scene.camera import Pinhole

#: A warning follows this many passes in a row that store no photon.
EMPTY_PASSES_WARNING = 10


class NoCausticWarning(UserWarning):
    """The scene has no specular object or no photon reached a receiver."""


class EmptyPassesWarning(UserWarning):
    """Many passes in a row stored no caustic photon."""


@dataclass
class PassStats:
    """What one merged pass did."""

    index: int
    stored: int
    emitted: int
    scale: float
    timings: dict = field(default_factory=dict)


class Renderer:
    """A progressive render of ``scene`` (module docstring): :meth:`step` runs the next pass in
    this process, :meth:`merge` adds a pass run anywhere, :attr:`image` is the image so far
    (:class:`blockhash.frame.result.RenderResult`).

    ``photons``: caustic photons stored in the first pass (every later pass emits as many as
    the first did), or a traced map (``CausticPhotons``) for a one-pass render.  ``spp``:
    samples per pixel per pass (:func:`blockhash.scene.camera.spp_grid` lays them out).
    ``indirect``: trace the light between diffuse
    surfaces where the scene has it (False: leave it out).  The rest as
    :func:`.pipeline.render`.
    """

    def __init__(self, scene, *, photons=None, spp: int = 1, seed=None,
                 estimate: EstimateOptions = EstimateOptions(), lookup: LookupOptions = LookupOptions(),
                 backend=None, schedule: Schedule = Schedule(), indirect: bool = True,
                 device: str | None = None):
        traced = None if photons is None or isinstance(photons, (int, np.integer)) else photons
        self.scene = scene
        self.settings = PassSettings.of(scene, photons=None if traced is not None else photons,
                                        spp=spp, seed=seed, estimate=estimate, lookup=lookup,
                                        backend=backend, schedule=schedule, indirect=indirect,
                                        device=device)
        if traced is not None:
            from dataclasses import replace

            self.settings = replace(self.settings, count=None)
        self.traced = traced
        self._setup = None
        pin = Pinhole.of(scene.camera)
        self.film = Film(pin.height, pin.width)
        self.timings: dict = {}
        self.info: dict = {"estimate": estimate.label, "spp": self.spp_per_pass}
        #: Photons every pass after the first emits: pass 0's emitted count.
        self.emitted_per_pass = None
        self.stored = self.emitted = 0
        self.empty_run = 0
        self.index = self.radii = None
        self._pending: dict[int, PassContribution] = {}

    @property
    def spp_per_pass(self) -> int:
        rows, cols = self.settings.grid
        return rows * cols

    @property
    def setup(self) -> RenderSetup:
        """This process's :class:`.task.RenderSetup`, built on first use."""
        if self._setup is None:
            self._setup = RenderSetup(self.scene, self.settings, self.traced)
        return self._setup

    @property
    def spec(self):
        """What a worker process needs to build the setup: (scene, settings, traced map)."""
        return self.scene, self.settings, self.traced

    @property
    def passes(self) -> int:
        """Passes merged into the film (passes 0 .. passes - 1)."""
        return self.film.passes

    def step(self) -> PassStats:
        """Run the next pass in this process and add it to the film."""
        self.index = self.radii = None  # the last pass's go before this pass's photons come
        merged = self.merge(run_pass(self.setup, self.passes, self.emitted_per_pass))
        return merged[-1]

    def merge(self, contribution: PassContribution) -> list[PassStats]:
        """Add ``contribution`` to the film once every pass before it is in; returns the passes
        merged now, in pass order (none while an earlier pass is missing)."""
        p = contribution.index
        if p < self.passes or p in self._pending:
            raise ValueError(f"pass {p} is already in the film or waiting for it; a pass is "
                             "merged once")
        self._pending[p] = contribution
        merged = []
        while self.passes in self._pending:
            merged.append(self._add(self._pending.pop(self.passes)))
        return merged

    def _add(self, c: PassContribution) -> PassStats:
        self.film.add(c.direct, c.caustic, c.emitted, c.indirect, c.indirect_emitted,
                      source=f"pass {c.index} ({c.info.get('ran_in', 'rendered in this process')})")
        for category, message in c.info.pop("warnings", ()):  # raised in a worker process
            warnings.warn(message, category, stacklevel=4)
        if c.index == 0:
            self.emitted_per_pass = c.emitted
            self.info.update({k: v for k, v in c.info.items()
                              if k in ("index", "indirect", "device")})
        for name, sec in c.timings.items():
            self.timings[name] = self.timings.get(name, 0.0) + sec
        if c.photon_index is not None or c.index == 0:
            self.index, self.radii = c.photon_index, c.radii
        self._count(c)
        return PassStats(c.index, c.stored, c.emitted, c.scale, c.timings)

    def _count(self, c: PassContribution) -> None:
        self.stored += c.stored
        self.emitted += c.emitted
        if c.index == 0 and c.stored == 0 and not self.scene.photons.direct_only:
            why = ("the scene has no specular object" if not self.scene.specular_objects
                   else no_caustic_reason(c.info.get("photon_stats", {})))
            warnings.warn(f"rendering direct light only: {why}", NoCausticWarning, stacklevel=4)
        if self.scene.specular_objects and not self.scene.photons.direct_only:
            self.empty_run = self.empty_run + 1 if c.stored == 0 else 0
            if self.empty_run == EMPTY_PASSES_WARNING:
                warnings.warn(
                    f"{EMPTY_PASSES_WARNING} passes in a row stored no caustic photon (each "
                    f"emitted {c.emitted:,}); they count, so the image stays unbiased, but it "
                    "refines slowly: raise photons per pass (photons=)", EmptyPassesWarning,
                    stacklevel=4)

    @property
    def image(self) -> RenderResult:
        """The image so far (:class:`blockhash.frame.result.RenderResult`, float32 pixel means)."""
        info = {**self.info, "passes": self.passes, "photons_stored": self.stored,
                "photons_emitted": self.emitted, "estimated_error": self.film.estimated_error(),
                "radius_scale": shrink(max(self.passes - 1, 0), self.settings.schedule.alpha)}
        return RenderResult(direct=self.film.direct.astype(np.float32),
                            caustic=self.film.caustic.astype(np.float32),
                            timings=dict(self.timings), info=info, index=self.index,
                            spp=self.spp_per_pass * self.passes, passes=self.passes,
                            radii=self.radii,
                            indirect=None if self.film.indirect is None
                            else self.film.indirect.astype(np.float32))
