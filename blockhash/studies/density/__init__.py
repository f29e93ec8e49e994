"""The density estimate's studies: :mod:`.estimates` its options against the reference
(``tools/estimate_study.py``), :mod:`.sampling` its done-when check from jittered pixel means,
and :mod:`.fold_bias` its excess beside a synthetic fold line (``tools/fold_bias.py``)."""
