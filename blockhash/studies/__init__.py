"""Studies: takes scenes and settings; gives measured trade-offs.  The trade study (speed
against accuracy of the caustic layer, ``blockhash tradeoff``) and the density-estimate
study (:mod:`.estimates`, :mod:`.sampling`, ``tools/estimate_study.py``).

:mod:`.sweep` runs the settings and measures them, :mod:`.measure` holds the error
measures, :mod:`.report` writes ``tradeoff.json``, the plots and ``report.md``, and
:mod:`.budget` picks settings for a time budget or a target error from a study.
"""

from blockhash.studies.sweep import QUICK, SweepPlan, run_sweep

__all__ = ["QUICK", "SweepPlan", "run_sweep"]
