"""The hash tables and their builders (paper sections 3.1, 4.2-4.3, 5): thresholds of the
marginal grid (:mod:`.thresholds`), the adaptive layout's kd-trees of cuts (:mod:`.adaptive`,
with :mod:`.probe`, :mod:`.partition`, :mod:`.taskpool`), the L tables of bucket references
(:mod:`.hashtables`), the parameters and presets (:mod:`.params`) and the node boxes that the
walk reads (:mod:`.node_boxes`)."""
