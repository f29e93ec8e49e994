"""The trade study: speed against accuracy of the caustic layer, measured (``blockhash tradeoff``).

:mod:`.sweep` runs the settings and measures them, :mod:`.measure` holds the error
measures, :mod:`.report` writes ``tradeoff.json``, the plots and ``report.md``, and
:mod:`.budget` picks settings for a time budget or a target error from a study.
"""

from .sweep import QUICK, SweepPlan, run_sweep

__all__ = ["QUICK", "SweepPlan", "run_sweep"]
