// bh_lookup.glsl: the whole Block Hashing query of one point (paper 4.4, section 7 steps 1-5).
// Takes: a float32 query position.  Returns: the k nearest photons found, in
// bh_best (keys: squared-distance bits, photon slot in block order), and the
// number of candidates examined.
// Defines: everything its includes take, plus BH_CAP (= A * k, candidates
// examined before stopping; the check precedes each block), BH_PROBE (1: multi-probe
// across the adaptive layout's nearest cuts while the cap allows), BH_DEDUP, and
// BH_TAKEN_MAX (bh_taken.glsl), BH_TAKE_LIMIT (the blocks a query stops at: L * B for
// hashing, for the walk its bound, never reached), BH_CULL (off | box: skip blocks that
// cannot hold a neighbour, same results; the walk culls whatever BH_CULL, and its culled
// blocks are not examined: bh_block_far), BH_FETCH_ONLY (1: fetch and measure the same candidates but keep none, the
// memory floor the benchmark compares with; bh_fetch_sink receives their sum),
// BH_BEST_FIRST (1: the default preset's nearest-box-first walk, bh_walk.glsl, replaces
// hashing, bucket order and probes).
// The CPU oracle is blockhash/index/lookups/hash.py bh_query (BH_BEST_FIRST: best_first.py
// bf_query); both give identical results.
#ifndef BH_LOOKUP_GLSL
#define BH_LOOKUP_GLSL
#include "bh_variants.glsl"
#include "bh_hash.glsl"
#include "bh_buckets.glsl"
#include "bh_blocks.glsl"
#include "bh_select.glsl"
#include "bh_select_packed.glsl"
#include "bh_select_merge.glsl"
#if BH_DEDUP == BH_DEDUP_SET
#include "bh_taken.glsl"
#endif

uint bh_fetch_sink = 0u;
uint bh_culled = 0u;  // blocks culled by the current lookup (BH_CULL box)

// A packed key -> (exact squared-distance bits, photon slot), or BH_NO_KEY.
// The taken list is an array (dedup branch, zero) or the register set of bh_taken.glsl.
#if BH_DEDUP == BH_DEDUP_SET
#define BH_TAKEN_AT(i) bh_taken_get(i)
#else
uint bh_taken_list[BH_TAKE_LIMIT];  // a query takes at most BH_TAKE_LIMIT blocks
#define BH_SCAN 32
#define BH_TAKEN_AT(i) bh_taken_list[i]
#endif

uvec2 bh_unpack(uint key, vec3 q) {
    if (key == BH_PK_EMPTY) {
        return BH_NO_KEY;
    }
    uint cand = key & BH_SLOT_MASK;
    uint b = BH_TAKEN_AT(cand / 10u);
    uint j = cand % 10u;
    vec3 p = bh_photon_position(b, j);
    precise vec3 d = p - q;
    precise float dd = (d.x * d.x + d.y * d.y) + d.z * d.z;
    return uvec2(floatBitsToUint(dd), b * 10u + j);
}

// The packed key of photon j of block b, the cand-th candidate (select packed, merge).
uint bh_packed_key(uint b, uint j, vec3 q, uint cand) {
    vec3 p = bh_photon_position(b, j);
    precise vec3 d = p - q;
    precise float dd = (d.x * d.x + d.y * d.y) + d.z * d.z;
    return (floatBitsToUint(dd) & ~BH_SLOT_MASK) | cand;
}

// Block culling (BH_CULL box): whether no photon of the block whose head is h can
// enter the k nearest, because the lower bound of its squared distances exceeds the
// current k-th key.  Its photons are then neither fetched nor offered; they still count
// as examined and the block as taken, so the result is the same as without culling.
// The walk (BH_BEST_FIRST) always culls, whatever BH_CULL, and otherwise: a far block is
// not taken and its photons are not examined, so they do not count toward BH_CAP
// (blockhash/index/lookups/walk.py, the same bound and comparison on the CPU).
#if BH_BEST_FIRST && !BH_FETCH_ONLY
#define BH_WALK_CULL 1
#else
#define BH_WALK_CULL 0
#endif
#if BH_CULL == BH_CULL_BOX && !BH_FETCH_ONLY || BH_WALK_CULL
bool bh_block_far(uvec4 h, vec3 q) {
    float lb = bh_block_gap2(h, q);
    uint bits = floatBitsToUint(lb);
#if BH_SELECT == BH_SELECT_PACKED
    bool far = lb > 0.0 && bits > (bh_pk[BH_K - 1] | BH_SLOT_MASK);
#elif BH_SELECT == BH_SELECT_MERGE
    bool far = lb > 0.0 && bits > (bh_ms[BH_K - 1] | BH_SLOT_MASK);
#else
    bool far = lb > 0.0 && bits > bh_best[BH_K - 1].x;
#endif
    bh_culled += uint(far);
    return far;
}
#elif BH_CULL != BH_CULL_OFF && BH_CULL != BH_CULL_BOX
#error unknown BH_CULL
#endif

// select=merge: block b's keys into the batch, constant slot j, empty beyond its n photons.
#define BH_MB_TAKE(j) bh_mb[j] = (uint(j) < n) ? bh_packed_key(b, uint(j), q, ntaken * 10u + uint(j)) | kill : BH_PK_EMPTY;

// Take the not yet taken blocks of bucket key of table t (nref valid references), in
// reference order, while under the candidate cap and BH_TAKE_LIMIT blocks (hashing: the
// L * B blocks a query can take, probes included; the walk: its bound, never reached).
void bh_take(uint t, uint key, uint nref, vec3 q, inout uint ntaken, inout uint count) {
    for (uint r = 0u; r < nref; ++r) {
        if (count >= uint(BH_CAP) || ntaken >= uint(BH_TAKE_LIMIT)) {
            break;
        }
        uint b = bh_ref(t, key, r);
#if BH_DEDUP == BH_DEDUP_SET
        bool dup = bh_taken_has(b);
#else
        // Scanned in chunks of BH_SCAN unrolled compares: llvmpipe counts only the
        // chunks against its loop budget (blockhash/gl/limits.py).
        bool dup = false;
        for (uint c = 0u; c < ntaken; c += uint(BH_SCAN)) {
            for (int u = 0; u < BH_SCAN; ++u) {
                uint j = c + uint(u);
                dup = dup || (j < ntaken && bh_taken_list[min(j, uint(BH_TAKE_LIMIT - 1))] == b);
            }
        }
#endif
#if BH_DEDUP == BH_DEDUP_BRANCH || BH_DEDUP == BH_DEDUP_SET
        if (dup) {
            continue;
        }
        uint kill = 0u;
#elif BH_DEDUP == BH_DEDUP_ZERO
        uint kill = dup ? 0xFFFFFFFFu : 0u;  // the redundant block's photons count for nothing
#else
#error unknown BH_DEDUP
#endif
#if BH_WALK_CULL
        uvec4 head = bh_block_head(b);
        uint n = head.x;
        if (bh_block_far(head, q)) {
            continue;  // not taken, not examined, not counted
        }
        {
#elif BH_CULL == BH_CULL_BOX && !BH_FETCH_ONLY
        uvec4 head = bh_block_head(b);
        uint n = head.x;
        if (!bh_block_far(head, q)) {
#else
        uint n = bh_block_count(b);
        {
#endif
#if BH_SELECT == BH_SELECT_MERGE && !BH_FETCH_ONLY
        BH_MB_TAKE(0) BH_MB_TAKE(1) BH_MB_TAKE(2) BH_MB_TAKE(3) BH_MB_TAKE(4)
        BH_MB_TAKE(5) BH_MB_TAKE(6) BH_MB_TAKE(7) BH_MB_TAKE(8) BH_MB_TAKE(9)
        bh_merge_block();
#else
        for (uint j = 0u; j < n; ++j) {
            vec3 p = bh_photon_position(b, j);
            precise vec3 d = p - q;
            precise float dd = (d.x * d.x + d.y * d.y) + d.z * d.z;
#if BH_FETCH_ONLY
            bh_fetch_sink += floatBitsToUint(dd) | kill;
#elif BH_SELECT == BH_SELECT_PACKED
            bh_packed_offer(((floatBitsToUint(dd) & ~BH_SLOT_MASK) | (ntaken * 10u + j)) | kill);
#else
            bh_select_offer(uvec2(floatBitsToUint(dd) | kill, (b * 10u + j) | kill));
#endif
        }
#endif
        }
        if (!dup) {
#if BH_DEDUP == BH_DEDUP_SET
            bh_taken_put(ntaken, b);
#else
            bh_taken_list[ntaken] = b;
#endif
            ntaken += 1u;
            count += n;
        }
    }
}

#if BH_BEST_FIRST
#if !BH_ADAPTIVE
#error BH_BEST_FIRST walks the adaptive layout's node boxes: it needs BH_ADAPTIVE
#endif
#include "bh_walk.glsl"
#endif

uint bh_lookup(vec3 q) {
#if BH_SELECT == BH_SELECT_MERGE
    bh_merge_init();
#elif BH_SELECT == BH_SELECT_PACKED
    bh_packed_init();
#else
    bh_select_init();
#endif
    uint ntaken = 0u;
    uint count = 0u;
#if BH_BEST_FIRST
#if BH_DEDUP == BH_DEDUP_SET
    bh_taken_init();
#endif
    bh_walk(q, ntaken, count);
#else
    uvec3 code = bh_quantize(q);
    uint keys[BH_L];
#if BH_ADAPTIVE
    vec3 cut_gap[BH_L];
    uvec3 cut_axis[BH_L];
    uvec3 cut_code[BH_L];
    for (int t = 0; t < BH_L; ++t) {
        keys[t] = bh_descend(uint(t), code);
        cut_gap[t] = bh_cut_gap;
        cut_axis[t] = bh_cut_axis;
        cut_code[t] = bh_cut_code;
        bh_depth_key[t] = ~floatBitsToUint(bh_cut_gap.x);
    }
#else
    for (int t = 0; t < BH_L; ++t) {
        keys[t] = bh_bucket_of(uint(t), code);
    }
#endif
#if BH_DEDUP == BH_DEDUP_SET
    // Tables visited by rank, each picked by comparisons over constant indices.
    uint rank[BH_L];
    uint entries[BH_L];
    bh_rank_tables(keys, rank, entries);
    bh_taken_init();
#else
    uint order[BH_L];
    uint entries[BH_L];
    bh_order_tables(keys, order, entries);
#endif
    for (int oi = 0; oi < BH_L; ++oi) {
        if (count >= uint(BH_CAP)) {
            break;
        }
#if BH_DEDUP == BH_DEDUP_SET
        uint t = 0u;
        uint key = 0u;
        uint nref = 0u;
        for (int u = 0; u < BH_L; ++u) {
            bool here = rank[u] == uint(oi);
            t = here ? uint(u) : t;
            key = here ? keys[u] : key;
            nref = here ? entries[u] : nref;
        }
#else
        uint t = order[oi];
        uint key = keys[t];
        uint nref = entries[t];
#endif
        bh_take(t, key, nref, q, ntaken, count);
    }
#if BH_PROBE && BH_ADAPTIVE
    // Multi-probe (blockhash/index/lookups/hash.py step 4): across each table's nearest cut, in
    // the same table order, then the second nearest, then the third.
    for (int j = 0; j < BH_PROBE_CUTS; ++j) {
        for (int oi = 0; oi < BH_L; ++oi) {
            if (count >= uint(BH_CAP)) {
                break;
            }
#if BH_DEDUP == BH_DEDUP_SET
            uint t = 0u;
            for (int u = 0; u < BH_L; ++u) {
                t = rank[u] == uint(oi) ? uint(u) : t;
            }
#else
            uint t = order[oi];
#endif
            if (isinf(cut_gap[t][j])) {
                continue;
            }
            uvec3 pc = code;
            pc[cut_axis[t][j]] = cut_code[t][j];
            uint key = bh_bucket_of(t, pc);
            if (key != keys[t]) {
                bh_take(t, key, bh_header(t, key).y, q, ntaken, count);
            }
        }
    }
#endif
#endif  // BH_BEST_FIRST
#if BH_SELECT == BH_SELECT_MERGE && !BH_FETCH_ONLY
    // Unpack the winners into (exact distance bits, photon slot) keys.
#define BH_MS_UNPACK1(i) if (i < BH_K) bh_best[i] = bh_unpack(bh_ms[i], q);
#define BH_MS_UNPACK8(i) BH_MS_UNPACK1(i) BH_MS_UNPACK1(i + 1) BH_MS_UNPACK1(i + 2) BH_MS_UNPACK1(i + 3) \
                         BH_MS_UNPACK1(i + 4) BH_MS_UNPACK1(i + 5) BH_MS_UNPACK1(i + 6) BH_MS_UNPACK1(i + 7)
    BH_PK_GROUPS(BH_MS_UNPACK8)  // groups of 8 up to k: bh_best's size
#elif BH_SELECT == BH_SELECT_PACKED && !BH_FETCH_ONLY
    // Unpack the winners into (exact distance bits, photon slot) keys.
#define BH_UNPACK1(i) if (i < BH_K) bh_best[i] = bh_unpack(bh_pk[i], q);
#define BH_UNPACK8(i) BH_UNPACK1(i) BH_UNPACK1(i + 1) BH_UNPACK1(i + 2) BH_UNPACK1(i + 3) \
                      BH_UNPACK1(i + 4) BH_UNPACK1(i + 5) BH_UNPACK1(i + 6) BH_UNPACK1(i + 7)
    BH_PK_GROUPS(BH_UNPACK8)
#endif
    return count;
}

#endif
