"""Studies: takes scenes and settings; gives measured trade-offs.  By study:

- The trade study (speed against accuracy of the caustic layer, ``blockhash tradeoff``):
  :mod:`.sweep` runs the settings and measures them, :mod:`.measure` holds the error measures,
  :mod:`.report` writes ``tradeoff.json``, the plots and ``report.md``, :mod:`.claims` the
  study's claims, and :mod:`.budget` picks settings for a time budget or a target error.
- The density estimate: :mod:`.estimates` its options against the reference,
  :mod:`.sampling` its done-when check from jittered pixel means
  (``tools/estimate_study.py``), :mod:`.fold_bias` its excess beside a synthetic fold line.
- The index: :mod:`.accuracy_runs` the accuracy runs on named photon maps beside the exact k
  nearest (``tools/eval_accuracy.py`` and its peers), :mod:`.cover_reads` what the cover
  gather reads per shading point.
- The shaders: :mod:`.bench`, the measuring behind ``blockhash bench`` (the lookups against
  exact kNN, and the caustic pass's peers, :mod:`.splat_pass` the GL photon splat among them),
  and :mod:`.gpu_compiler`, a GPU compiler's view of them (registers, scratch, occupancy on
  Mesa RADV's null device).
- The render against Mitsuba: :mod:`.caustic_reference`, the caustic layer held to a cached
  Mitsuba reference (``tools/pass_convergence.py``, ``tools/time_to_error.py``).

:mod:`.command` is what the commands in ``tools/`` share: their argument types (photon
counts, sizes, scenes), the scenes of the checkout, timing and JSON output.
"""

from blockhash.studies.sweep import QUICK, SweepPlan, run_sweep

__all__ = ["QUICK", "SweepPlan", "run_sweep"]
