"""The index's studies: :mod:`.accuracy_runs` the accuracy runs on named photon maps beside
the exact k nearest (``tools/eval_accuracy.py`` and its peers), :mod:`.cover_reads` what the
cover gather reads per shading point (``tools/cover_stats.py``)."""
