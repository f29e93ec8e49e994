"""Studies: takes scenes and settings; gives measured trade-offs.  A room per study:

- :mod:`.tradeoff`: speed against accuracy of the caustic layer (``blockhash tradeoff``);
- :mod:`.density`: the density estimate's options, its done-when check and its excess
  beside a fold;
- :mod:`.lookups`: the index's accuracy runs and the cover gather's reads;
- :mod:`.shaders`: ``blockhash bench``'s measuring and the GPU compiler's view of the shaders.

Shared by them: :mod:`.measure` (the error measures), :mod:`.caustic_reference` (the caustic
layer held to a cached Mitsuba reference: ``tools/pass_convergence.py``,
``tools/time_to_error.py``) and :mod:`.command`, what the commands in ``tools/`` share: their
argument types (photon counts, sizes, scenes), the scenes of the checkout, timing and JSON
output.
"""

from blockhash.studies.tradeoff.sweep import QUICK, SweepPlan, run_sweep

__all__ = ["QUICK", "SweepPlan", "run_sweep"]
