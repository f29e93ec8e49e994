"""How a progressive render proceeds: :class:`RenderPlan`, its stopping rule, its radius
schedule and where its passes run.  ("passes" is always a count: the most a plan runs,
``RenderPlan.passes``, or those merged, ``Renderer.passes``.)

A render stops at the first of its rules that holds: ``passes`` passes run, ``seconds``
elapsed, or the caustic layer's estimated relative standard error
(:meth:`blockhash.passes.film.Film.estimated_error`, from the spread between passes) at most
``target_error``.  A target is checked from :data:`PROJECT_AFTER` passes on against the pass
limit: the error of the mean falls about as ``n^(-alpha / 2)`` over n passes (Knaus and
Zwicker: a pass's variance grows as ``n^(1 - alpha)``), so a target that the projection puts
beyond ``PROJECTION_MARGIN`` times ``passes`` is refused then, naming the passes it needs,
rather than run to the limit; a target still unmet at the limit is refused there.  (The
command line writes the image so far in both cases.)

With passes running in parallel (``executor``), the plan decides which passes are handed out
(:meth:`RenderPlan.hand_out`) and when the merged film stops (:meth:`RenderPlan.reason`): the film
holds passes 0..n-1 in order, so ``passes=N`` renders exactly passes 0..N-1, and a time or a
target stops with a contiguous run of passes from 0, whatever was still in flight.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from blockhash.errors import InputError
from blockhash.passes.executors import InProcess
from blockhash.passes.schedule import Schedule
from blockhash.validate import INDIRECT, as_flag

#: Passes of the default render (with one sample per pixel per pass and the scene's photons
#: per pass): chosen on the ring scene at 512 x 512 against the single render (BENCHMARKS.md, "The render in passes").
DEFAULT_PASSES = 4
#: A target error is projected against the pass limit from this many passes on.
PROJECT_AFTER = 4
#: A target error whose projected passes exceed the limit by this factor is refused.
PROJECTION_MARGIN = 2.0


@dataclass(frozen=True)
class RenderPlan:
    """How a render proceeds: its stopping rule, its radius schedule and where its passes run
    (module docstring).

    passes : int >= 1 or None          most passes (None: no limit; then ``seconds`` or
                                       ``target_error`` must stop the render)
    seconds : float > 0 or None        stop once this much time has passed (checked after
                                       each pass)
    target_error : float > 0 or None   stop once the caustic layer's estimated relative
                                       standard error is at most this (needs two passes)
    schedule : Schedule                alpha and the footprint (:mod:`.schedule`)
    executor : InProcess, LocalWorkers or DaskCluster
                                       where the passes run (:mod:`.executors`; default in
                                       this process); the image is the same
    indirect : bool                    render the light between diffuse surfaces (the
                                       ``indirect`` layer, :mod:`blockhash.photons.indirect`)
                                       where the scene has it (default True); False leaves it
                                       out, for caustic-only studies: no layer, not a zero one
    device : str or None               where the caustic photons are traced: 'auto', 'cpu',
                                       'gpu' or 'host' (:mod:`blockhash.device.choice`; None:
                                       the environment's BLOCKHASH_DEVICE, else 'auto'),
                                       resolved by each process that runs passes
    """

    passes: int | None = DEFAULT_PASSES
    seconds: float | None = None
    target_error: float | None = None
    schedule: Schedule = field(default_factory=Schedule)
    executor: object = field(default_factory=InProcess)
    indirect: bool = True
    device: str | None = None

    def __post_init__(self):
        from blockhash.device.choice import device_name

        as_flag(self.indirect, "indirect", INDIRECT)
        if self.device is not None:
            device_name(self.device)
        if self.passes is not None and (isinstance(self.passes, bool) or
                                        not isinstance(self.passes, int) or self.passes < 1):
            raise InputError.about("{passes}{value!r}: a render runs at least one pass; give "
                                   "{passes}N with N >= 1 (or leave it out to stop by {seconds} "
                                   "or {target_error})", value=self.passes)
        if self.seconds is not None and not (_number(self.seconds) and 0 < self.seconds < math.inf):
            raise InputError.about("{seconds}{value!r}: the time limit must be a positive, "
                                   "finite number of seconds; give e.g. {seconds}30",
                                   value=self.seconds)
        if self.target_error is not None and not (_number(self.target_error)
                                                  and 0 < self.target_error < math.inf):
            raise InputError.about("{target_error}{value!r}: the caustic layer's relative "
                                   "standard error to stop at must be > 0; give e.g. "
                                   "{target_error}0.05", value=self.target_error)
        if self.passes is None and self.seconds is None and self.target_error is None:
            raise InputError.about("a render with no pass limit needs {seconds} or {target_error} "
                                   "to stop; give {passes}N, {seconds}SECONDS or "
                                   "{target_error}E")
        if not hasattr(self.executor, "open"):
            raise InputError(f"executor={self.executor!r}: give InProcess(), LocalWorkers(count) "
                             "or DaskCluster(address) (blockhash.passes.executors)")
        if self.target_error is not None and self.passes is not None and self.passes < 2:
            raise InputError.about("{target_error}{target} cannot be reached within "
                                   "{passes}{passes_value}: the error is estimated from the spread "
                                   "between passes, so it needs at least 2; raise {passes} or drop "
                                   "{target_error}", target=self.target_error,
                                   passes_value=self.passes)

    @property
    def one_pass(self) -> bool:
        """One pass and no other rule: the single render (``render_scene``'s)."""
        return self.passes == 1

    def hand_out(self, p: int, elapsed: float) -> bool:
        """Whether pass ``p`` may start now: below the pass limit and within the time (pass 0
        always: a render runs at least one pass)."""
        if p == 0:
            return True
        if self.passes is not None and p >= self.passes:
            return False
        return self.seconds is None or elapsed < self.seconds

    def reason(self, renderer, elapsed: float) -> str | None:
        """Why the render stops now (None: it goes on); :class:`TargetOutOfReach` for a
        target not met at the pass limit, or that the projection puts out of its reach."""
        n = renderer.passes
        if self.target_error is not None and n >= 2:
            err = renderer.film.estimated_error()
            if err <= self.target_error:
                return f"estimated error {err:.3g} <= target {self.target_error:g}"
            if self.passes is not None and (n >= self.passes or n >= PROJECT_AFTER):
                need = (n * (err / self.target_error) ** (2.0 / self.schedule.alpha)
                        if math.isfinite(err) else math.inf)
                if n >= self.passes or need > PROJECTION_MARGIN * self.passes:
                    raise TargetOutOfReach.about(
                        "{target_error}{target:g} cannot be reached within {passes}{limit}: "
                        "after {n} passes the estimated error is {err:.3g}, which needs about "
                        "{need:,.0f} passes at alpha {alpha:.3g}; raise {passes}, raise the "
                        "target, or give more {photons}per pass", target=self.target_error,
                        limit=self.passes, n=n, err=err, need=need, alpha=self.schedule.alpha)
        if self.passes is not None and n >= self.passes:
            return f"{n} pass{'es' if n > 1 else ''}"
        if self.seconds is not None and elapsed >= self.seconds:
            return f"time limit {self.seconds:g} s"
        return None


class TargetOutOfReach(InputError):
    """The target error needs far more passes than the render may run."""


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)
