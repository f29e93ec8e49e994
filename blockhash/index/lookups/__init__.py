"""The lookups, each the CPU reference of the shader named alike in glsl/: the hash query
(:mod:`.hash`, glsl/bh_hash.glsl, bh_buckets.glsl, bh_lookup.glsl), the nearest-box-first walk
(:mod:`.walk`, glsl/bh_walk.glsl), the Hilbert cells (:mod:`.cells`, :mod:`.cells_query`,
glsl/bh_cells.glsl; :mod:`.cell_cover`, the least a lookup of whole cells must read), the
cover gather (:mod:`.cover`, glsl/bh_cover.glsl); the exact kNN baseline (:mod:`.exact`,
cKDTree) and the exact j-th neighbour of every photon (:mod:`.octree_knn`, the photon radii)."""
