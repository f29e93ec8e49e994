// bh_walk.glsl: the default preset's nearest-box-first walk over the adaptive tables.
// Takes: a float32 query position, and the blocks taken and candidates examined so far.
// Returns: the candidates of every bucket the walk reaches, offered to the selection by
// bh_take (bh_lookup.glsl), which must be defined before this file is included.
// Exactly blockhash/index/lookups/walk.py bf_query: a queue of (squared distance to the
// node's box as float32 bits, node id = t * BH_NODES + i) seeded with the roots of the
// first BH_WALK_TREES tables; repeat at most BH_MAX_POPS times: stop at the cap (the
// walk has no block cap) or with an empty queue; pop the smallest (distance, id); stop
// when it is farther than the k-th key (bh_kth_bits); a bucket node: stop after
// BH_MAX_LEAVES buckets, else take its blocks; an inner node: push each child with
// photons whose box is not farther than the k-th.
// The queue holds BH_QUEUE entries in plain arrays scanned in unrolled chunks of 32;
// a push onto a full queue drops the largest of its entries and the new one.
// Textures: bh_boxes RGBA32UI, node id n at texels 2n (lo xyz bits, 1 if it holds
// photons) and 2n + 1 (hi xyz bits, 0) (blockhash/gl/packing.py).
// Defines: BH_NODES (nodes per table row, BH_T / 2), BH_WALK_TREES (1 .. BH_L),
// BH_QUEUE (a multiple of 32), BH_MAX_POPS, BH_MAX_LEAVES, BH_BOX_W (texture width, log2).
#ifndef BH_WALK_GLSL
#define BH_WALK_GLSL
#include "bh_fetch.glsl"

#if BH_QUEUE % 32 != 0 || BH_QUEUE < 32
#error BH_QUEUE must be a positive multiple of 32 (the queue is scanned in chunks of 32)
#endif

uniform usampler2D bh_boxes;

uint bh_qd[BH_QUEUE];  // squared distance bits
uint bh_qn[BH_QUEUE];  // node id
uint bh_qsize = 0u;

// Whether node id holds photons; if so, d receives the float32 bits of q's squared
// distance to its box, ((gx*gx + gy*gy) + gz*gz) with g = max(max(lo - q, q - hi), 0).
bool bh_node_box(uint id, vec3 q, out uint d) {
    uvec4 lo = bh_fetch4(bh_boxes, BH_BOX_W, 2u * id);
    uvec4 hi = bh_fetch4(bh_boxes, BH_BOX_W, 2u * id + 1u);
    precise vec3 g = max(max(uintBitsToFloat(lo.xyz) - q, q - uintBitsToFloat(hi.xyz)), vec3(0.0));
    precise float dd = (g.x * g.x + g.y * g.y) + g.z * g.z;
    d = floatBitsToUint(dd);
    return lo.w != 0u;
}

// The k-th key's distance bits as the walk compares them: 0xFFFFFFFF (prune nothing)
// until k candidates are held; packed keys with their slot bits set.
uint bh_kth_bits() {
#if BH_SELECT == BH_SELECT_PACKED
    return bh_pk[BH_K - 1] | BH_SLOT_MASK;
#elif BH_SELECT == BH_SELECT_MERGE
    return bh_ms[BH_K - 1] | BH_SLOT_MASK;
#else
    return bh_best[BH_K - 1].x;
#endif
}

bool bh_entry_less(uint da, uint na, uint db, uint nb) {
    return da < db || (da == db && na < nb);
}

// Index of the smallest (distance, id) entry of a non-empty queue.
uint bh_queue_min() {
    uint j = 0u;
    for (uint c = 0u; c < bh_qsize; c += 32u) {
        for (int u = 0; u < 32; ++u) {
            uint i = min(c + uint(u), uint(BH_QUEUE - 1));
            j = (c + uint(u) < bh_qsize && bh_entry_less(bh_qd[i], bh_qn[i], bh_qd[j], bh_qn[j])) ? i : j;
        }
    }
    return j;
}

void bh_queue_push(uint d, uint id) {
    if (bh_qsize < uint(BH_QUEUE)) {
        bh_qd[bh_qsize] = d;
        bh_qn[bh_qsize] = id;
        bh_qsize += 1u;
        return;
    }
    uint j = 0u;  // the largest entry
    for (uint c = 0u; c < uint(BH_QUEUE); c += 32u) {
        for (int u = 0; u < 32; ++u) {
            uint i = c + uint(u);
            j = bh_entry_less(bh_qd[j], bh_qn[j], bh_qd[i], bh_qn[i]) ? i : j;
        }
    }
    if (bh_entry_less(d, id, bh_qd[j], bh_qn[j])) {
        bh_qd[j] = d;
        bh_qn[j] = id;
    }
}

void bh_walk(vec3 q, inout uint ntaken, inout uint count) {
    bh_qsize = 0u;
    uint d;
    for (int t = 0; t < BH_WALK_TREES; ++t) {
        uint root = uint(t) * uint(BH_NODES);
        if (bh_node_box(root, q, d)) {
            bh_queue_push(d, root);
        }
    }
    uint leaves = 0u;
    for (int it = 0; it < BH_MAX_POPS; ++it) {
        if (count >= uint(BH_CAP) || bh_qsize == 0u) {
            break;
        }
        uint j = bh_queue_min();
        uint dist = bh_qd[j];
        uint id = bh_qn[j];
        bh_qsize -= 1u;
        bh_qd[j] = bh_qd[bh_qsize];
        bh_qn[j] = bh_qn[bh_qsize];
        uint kth = bh_kth_bits();
        if (dist > kth) {
            break;
        }
        uint t = id / uint(BH_NODES);
        uint i = id - t * uint(BH_NODES);
        uint meta = bh_fetch1(bh_thresholds, BH_THR_W, t * uint(BH_T) + 2u * i + 1u);
        if ((meta & 4u) != 0u) {
            if (leaves >= uint(BH_MAX_LEAVES)) {
                break;
            }
            leaves += 1u;
            uint key = meta >> 3u;
            bh_take(t, key, bh_header(t, key).y, q, ntaken, count);
        } else {
            uint c = t * uint(BH_NODES) + (meta >> 3u);
            if (bh_node_box(c, q, d) && d <= kth) {
                bh_queue_push(d, c);
            }
            if (bh_node_box(c + 1u, q, d) && d <= kth) {
                bh_queue_push(d, c + 1u);
            }
        }
    }
}

#endif
