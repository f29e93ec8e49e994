"""The loop of a render: :func:`run_passes` hands passes to an executor while the stopping
rule allows, merges what ends into the film in pass order, and stops when the rule says so.

Pass 0 runs alone (it fixes the photons every later pass emits); then as many passes are in
flight as the executor has slots.
"""

from __future__ import annotations

import time

from blockhash.passes.plan import RenderPlan
from blockhash.passes.worker import refuse_while_importing_main


def run_passes(renderer, plan: RenderPlan, *, on_pass=None, on_wait=None):
    """Run ``renderer``'s passes on ``plan.executor`` until ``plan`` says stop;
    ``on_pass(renderer, stats, elapsed, session)`` after every pass merged, ``on_wait(session)``
    after passes are handed out.  Returns the reason it stopped (also in
    ``renderer.info['stopped_by']``); Ctrl-C and a pass that raised leave the film with the
    passes merged so far.  A spawned worker process that reaches a render while importing its
    parent's script (no main guard) ends here (:func:`.worker.refuse_while_importing_main`)."""
    refuse_while_importing_main()
    t0 = time.perf_counter()
    with plan.executor.open(renderer) as session:
        renderer.info["workers"] = session.workers
        renderer.info["executor"] = plan.executor.describe()
        nxt = renderer.passes
        while True:
            elapsed = time.perf_counter() - t0
            first = renderer.emitted_per_pass is None and renderer.passes == 0
            while (session.in_flight < (1 if first else session.slots)
                   and plan.hand_out(nxt, elapsed) and not (first and nxt > 0)):
                session.submit(nxt, renderer.emitted_per_pass)
                nxt += 1
            if not session.in_flight:  # nothing may start: the plan must say why
                why = plan.reason(renderer, elapsed) or "nothing left to hand out"
                renderer.info["stopped_by"] = why
                return why
            if on_wait is not None:
                on_wait(session)
            for _, contribution in session.results():
                for stats in renderer.merge(contribution):
                    elapsed = time.perf_counter() - t0
                    if on_pass is not None:
                        on_pass(renderer, stats, elapsed, session)
                    why = plan.reason(renderer, elapsed)
                    if why is not None:
                        renderer.info["stopped_by"] = why
                        return why

