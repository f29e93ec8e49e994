"""Studies: takes scenes and settings; gives measured trade-offs.  The trade study (speed
against accuracy of the caustic layer, ``blockhash tradeoff``) and the density-estimate
study (:mod:`.estimates`, :mod:`.sampling`, ``tools/estimate_study.py``; :mod:`.fold_bias`
the estimate's excess beside a synthetic fold line, ``tools/fold_bias.py``).

:mod:`.sweep` runs the settings and measures them, :mod:`.measure` holds the error
measures, :mod:`.report` writes ``tradeoff.json``, the plots and ``report.md``, and
:mod:`.budget` picks settings for a time budget or a target error from a study.
:mod:`.bench` is the measuring behind ``blockhash bench`` (the lookups against exact kNN,
and the caustic pass's peers, photon splatting among them: :mod:`.splat_pass`, the GL splat
that only the benchmarks and ``tools/shader_stats.py`` use); :mod:`.claims` writes the trade
study's claims.  :mod:`.gpu_compiler` is a GPU compiler's view of the shaders (registers, scratch,
occupancy on Mesa RADV's null device).
:mod:`.caustic_reference` holds the caustic layer to a cached Mitsuba reference
(``tools/pass_convergence.py``, ``tools/time_to_error.py``).  :mod:`.command` is what the commands in ``tools/`` share: their argument
types (photon counts, sizes, scenes), the scenes of the checkout, timing and JSON output.
:mod:`.accuracy_runs` are the index's accuracy runs on named photon maps beside the exact k
nearest (``tools/eval_accuracy.py`` and its peers), :mod:`.cover_reads` what the cover gather
reads per shading point (``tools/cover_stats.py``).
"""

from blockhash.studies.sweep import QUICK, SweepPlan, run_sweep

__all__ = ["QUICK", "SweepPlan", "run_sweep"]
