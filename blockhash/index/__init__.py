"""The Block Hashing index (paper sections 3-5), pure CPU: no GL, no scenes.

Data flows through these modules in this order: fixed-point positions and photon
records (:mod:`.fixedpoint`, :mod:`.codec`), Hilbert keys and 64-word blocks
(:mod:`.hilbert`, :mod:`.btree`, :mod:`.blocks`), adaptive thresholds and hash
tables (:mod:`.thresholds`, :mod:`.hashtables`), parameters (:mod:`.params`),
the CPU query that is the shader's oracle (:mod:`.query`), and the index object
that ties them together (:mod:`.block_hash_index`).  :mod:`.metrics` (exact kNN,
false negatives, dilations) and :mod:`.datasets` (synthetic photon sets) measure it.
"""

from blockhash.index.block_hash_index import BlockHashIndex, IndexStats, OrphanWarning

__all__ = ["BlockHashIndex", "IndexStats", "OrphanWarning"]
