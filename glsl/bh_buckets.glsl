// bh_buckets.glsl: first dependent fetch and bucket order (paper 4.4; section 7 steps 2-3).
// Takes: the L bucket keys of a query.  Returns: the table order to visit
// (bh_order_tables: a list; bh_rank_tables: each table's rank in it) and each
// bucket's valid references (bh_ref).
// Textures: bh_headers RG32UI (priority alpha, valid entries) per bucket
// t * BH_BUCKETS + key; bh_refs R32UI, BH_B references per bucket.
// Defines: BH_PRIORITY (on: smallest alpha first, ties in table order | off:
// table order), BH_L, BH_B, BH_BUCKETS, BH_HDR_W, BH_REF_W.  With BH_ADAPTIVE the
// priority is bh_depth_key[t] instead of alpha: the query's distance to the nearest cut
// of its path in table t, largest first (blockhash/index/lookups/hash.py step 2).

#ifndef BH_BUCKETS_GLSL
#define BH_BUCKETS_GLSL
#include "bh_fetch.glsl"

uniform usampler2D bh_headers;
uniform usampler2D bh_refs;

#if BH_ADAPTIVE
// ~floatBitsToUint(depth): ascending order of these keys is descending depth (depth >= 0).
uint bh_depth_key[BH_L];
#define BH_PRIO(t, h) bh_depth_key[t]
#else
#define BH_PRIO(t, h) (h).x
#endif

uvec2 bh_header(uint t, uint key) {
    return bh_fetch2(bh_headers, BH_HDR_W, t * uint(BH_BUCKETS) + key);
}

uint bh_ref(uint t, uint key, uint slot) {
    return bh_fetch1(bh_refs, BH_REF_W, (t * uint(BH_BUCKETS) + key) * uint(BH_B) + slot);
}

// Fills order[] with table indices; entries[t] receives the bucket's valid count.
void bh_order_tables(uint keys[BH_L], out uint order[BH_L], out uint entries[BH_L]) {
    uint prio[BH_L];
    for (int t = 0; t < BH_L; ++t) {
        uvec2 h = bh_header(uint(t), keys[t]);
        prio[t] = BH_PRIO(t, h);
        entries[t] = h.y;
        order[t] = uint(t);
    }
#if BH_PRIORITY == BH_PRIORITY_ON
    for (int t = 1; t < BH_L; ++t) {  // stable insertion sort by priority
        uint cur = order[t];
        int j = t;
        while (j > 0 && prio[order[j - 1]] > prio[cur]) {
            order[j] = order[j - 1];
            --j;
        }
        order[j] = cur;
    }
#elif BH_PRIORITY != BH_PRIORITY_OFF
#error unknown BH_PRIORITY
#endif
}

// The rank of each table in the visiting order, from comparisons alone: rank[t] =
// #{u : (prio[u], u) < (prio[t], t)} (priority on), the order of the stable sort
// above; rank[t] = t (off).  With every loop over the L tables of constant count
// (unrolled), prio[] and rank[] take only constant indices and stay in registers.
void bh_rank_tables(uint keys[BH_L], out uint rank[BH_L], out uint entries[BH_L]) {
#if BH_PRIORITY == BH_PRIORITY_ON
    uint prio[BH_L];
#endif
    for (int t = 0; t < BH_L; ++t) {
        uvec2 h = bh_header(uint(t), keys[t]);
        entries[t] = h.y;
#if BH_PRIORITY == BH_PRIORITY_ON
        prio[t] = BH_PRIO(t, h);
#endif
    }
    for (int t = 0; t < BH_L; ++t) {
#if BH_PRIORITY == BH_PRIORITY_ON
        uint r = 0u;
        for (int u = 0; u < BH_L; ++u) {
            r += uint(prio[u] < prio[t] || (prio[u] == prio[t] && u < t));
        }
        rank[t] = r;
#elif BH_PRIORITY == BH_PRIORITY_OFF
        rank[t] = uint(t);
#else
#error unknown BH_PRIORITY
#endif
    }
}

#endif
