"""The Block Hashing index (paper sections 3-5), pure CPU: no GL, no scenes.

Three parts, in the order data flows through them: the photon records and blocks
(:mod:`.records`), the hash tables and their builders (:mod:`.tables`), and the lookups
(:mod:`.lookups`: the hash query, the walk, the Hilbert cells, the cover gather, each the
CPU reference of the shader named alike in glsl/), tied together by the index object
(:mod:`.block_hash_index`).  What measures it (exact kNN metrics, synthetic photon sets,
photon maps on surfaces) is in :mod:`blockhash.evaluate`.
"""

from blockhash.index.block_hash_index import BlockHashIndex, IndexStats, OrphanWarning

__all__ = ["BlockHashIndex", "IndexStats", "OrphanWarning"]
