"""Selection of the m-th smallest without a full sort (Hoare's quickselect, median of three),
shared by the kd-tree shader's build (:mod:`blockhash.gl.kdtree_build`, its medians) and the
photon radii (:mod:`blockhash.index.lookups.octree_knn`, the j-th nearest distance)."""

from __future__ import annotations

import numba


@numba.njit(cache=True, nogil=True)
def select_by(perm, lo, hi, m, coord):
    """Partially sort perm[lo:hi] by coord[perm] so that perm[m] is the (m - lo)-th smallest,
    everything before it <= and everything after it >= (Hoare quickselect, median of three)."""
    while hi - lo > 1:
        mid = (lo + hi - 1) >> 1
        a, b, c = coord[perm[lo]], coord[perm[mid]], coord[perm[hi - 1]]
        if a < b:
            pivot = b if b < c else (c if a < c else a)
        else:
            pivot = a if a < c else (c if b < c else b)
        i, j = lo, hi - 1
        while i <= j:
            while coord[perm[i]] < pivot:
                i += 1
            while coord[perm[j]] > pivot:
                j -= 1
            if i <= j:
                t = perm[i]
                perm[i] = perm[j]
                perm[j] = t
                i += 1
                j -= 1
        # now perm[lo:j+1] <= pivot, perm[i:hi] >= pivot, perm[j+1:i] == pivot
        if m <= j:
            hi = j + 1
        elif m >= i:
            lo = i
        else:
            return
