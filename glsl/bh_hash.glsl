// bh_hash.glsl: hash keys of a query in every table (paper sections 3.1, 4.2, 7 step 1).
// Takes: the query's float32 position.  Returns: its uint32 fixed-point codes
// (bh_quantize) and its bucket in table t (bh_bucket_of).
// Defines: BH_THRESHOLD_SEARCH (linear | binary), BH_PX/BH_PY/BH_PZ buckets per
// axis (the marginal grid), BH_ADAPTIVE (1: the adaptive layout's kd-tree rows,
// which replace the grid), BH_T words per table
// row, BH_THR_W threshold texture width (log2), BH_MAX_DEPTH (adaptive descent bound),
// BH_PROBE_CUTS (adaptive: the nearest cuts bh_descend records for multi-probing).
// Exactly blockhash/index/records/fixedpoint.py quantize_query and
// blockhash/index/tables/thresholds.py bucket_of (adaptive_bucket_of; layout in
// blockhash/index/tables/adaptive.py).
#ifndef BH_HASH_GLSL
#define BH_HASH_GLSL
#include "bh_fetch.glsl"
#include "bh_box.glsl"

uniform usampler2D bh_thresholds;

// #{thresholds[base + i] <= code : i < count}; each list is sorted.
uint bh_count_le(uint base, uint count, uint code) {
#if BH_THRESHOLD_SEARCH == BH_SEARCH_LINEAR
    uint h = 0u;
    for (uint i = 0u; i < count; ++i) {
        h += uint(bh_fetch1(bh_thresholds, BH_THR_W, base + i) <= code);
    }
    return h;
#elif BH_THRESHOLD_SEARCH == BH_SEARCH_BINARY
    uint lo = 0u;
    uint hi = count;
    while (lo < hi) {
        uint mid = (lo + hi) >> 1u;
        if (bh_fetch1(bh_thresholds, BH_THR_W, base + mid) <= code) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
#else
#error unknown BH_THRESHOLD_SEARCH
#endif
}

#if BH_ADAPTIVE
// The PROBE_CUTS = 3 cuts of the last bh_descend nearest to the query: gap (float32 metres
// |code - t| * step, ascending, +inf where unused), axis, and the code across the cut
// (blockhash/index/tables/thresholds.py adaptive_descend).
#if BH_PROBE_CUTS != 3
#error bh_descend keeps exactly 3 cuts
#endif
vec3 bh_cut_gap;
uvec3 bh_cut_axis;
uvec3 bh_cut_code;

// Like bh_bucket_of, and records the path's three nearest cuts (ties keep path order).
uint bh_descend(uint t, uvec3 c) {
    uint row = t * uint(BH_T);
    uint i = 0u;
    bh_cut_gap = vec3(uintBitsToFloat(0x7F800000u));
    bh_cut_axis = uvec3(0u);
    bh_cut_code = uvec3(0u);
    for (int d = 0; d < BH_MAX_DEPTH; ++d) {
        uint meta = bh_fetch1(bh_thresholds, BH_THR_W, row + 2u * i + 1u);
        if ((meta & 4u) != 0u) {
            return meta >> 3u;
        }
        uint thr = bh_fetch1(bh_thresholds, BH_THR_W, row + 2u * i);
        uint a = meta & 3u;
        uint x = c[a];
        bool right = x >= thr;
        precise float gap = float((right ? x - thr : thr - x) >> 8u) * bh_step[a];  // below 2^24: exact
        uint across = right ? thr - 1u : thr;
        if (gap < bh_cut_gap.z) {
            if (gap < bh_cut_gap.y) {
                bh_cut_gap.z = bh_cut_gap.y; bh_cut_axis.z = bh_cut_axis.y; bh_cut_code.z = bh_cut_code.y;
                if (gap < bh_cut_gap.x) {
                    bh_cut_gap.y = bh_cut_gap.x; bh_cut_axis.y = bh_cut_axis.x; bh_cut_code.y = bh_cut_code.x;
                    bh_cut_gap.x = gap; bh_cut_axis.x = a; bh_cut_code.x = across;
                } else {
                    bh_cut_gap.y = gap; bh_cut_axis.y = a; bh_cut_code.y = across;
                }
            } else {
                bh_cut_gap.z = gap; bh_cut_axis.z = a; bh_cut_code.z = across;
            }
        }
        i = (meta >> 3u) + uint(right);
    }
    return 0xFFFFFFFFu;
}

// Node i: word 2i the threshold; word 2i+1 (left << 3) | axis, or (bucket << 3) | 4.
uint bh_bucket_of(uint t, uvec3 c) {
    uint row = t * uint(BH_T);
    uint i = 0u;
    for (int d = 0; d < BH_MAX_DEPTH; ++d) {
        uint meta = bh_fetch1(bh_thresholds, BH_THR_W, row + 2u * i + 1u);
        if ((meta & 4u) != 0u) {
            return meta >> 3u;
        }
        uint thr = bh_fetch1(bh_thresholds, BH_THR_W, row + 2u * i);
        i = (meta >> 3u) + uint(c[meta & 3u] >= thr);
    }
    return 0xFFFFFFFFu;
}
#else
uint bh_bucket_of(uint t, uvec3 c) {
    uint row = t * uint(BH_T);
    uint hx = bh_count_le(row, uint(BH_PX - 1), c.x);
    uint hy = bh_count_le(row + uint(BH_PX - 1), uint(BH_PY - 1), c.y);
    uint hz = bh_count_le(row + uint(BH_PX - 1 + BH_PY - 1), uint(BH_PZ - 1), c.z);
    return hx + uint(BH_PX) * (hy + uint(BH_PY) * hz);
}
#endif

#endif
