// kd_tree.glsl: exact k nearest photons by a balanced kd-tree search (paper section 2,
// the exact baseline that Block Hashing is compared with).
// Takes: a float32 query; the tree in kd_nodes (RGBA32UI, node i = texel i wrapped row by
// row: x, y, z float bits and photon index | split axis << 30), a heap-ordered complete
// tree: node i has children 2i+1 and 2i+2 where those are below KD_N
// (blockhash/gl/kdtree.py).
// Returns: the k best keys (float32 squared distance bits, photon index) in kd_heap, a
// max-heap (kd_heap[0] is the k-th nearest, the pruning radius; kd_heap_sort() sorts it
// ascending), the nodes visited, and whether the search finished.
// Defines: KD_K (k), KD_N (nodes), KD_DEPTH (tree height = stack size), KD_NODE_W (log2
// width of kd_nodes).
//
// Exactness: distances are ((dx*dx + dy*dy) + dz*dz) in float32 with d = p - q, as in
// bh_lookup.glsl.  A far child is skipped only when its float32 squared plane distance,
// a lower bound of every float32 distance below it (rounding is monotonic), exceeds the
// k-th distance, so the result is the float32 brute force on (distance, index) keys.
//
// llvmpipe stops every loop of a shader invocation once 65,535 loop iterations have run
// in total (gallivm's shared loop limiter; loops of up to 32 constant iterations are
// unrolled and do not count), silently.  So the search is one loop of small steps (visit
// a node, pop the stack, or move one level of a heap sift) that stops itself after a
// step budget with its whole state in kd_node, kd_sp, kd_stack_*, kd_heap, kd_visited:
// the caller saves it and resumes in a later pass.  A step budget of B costs at most
// B + log2(k) + 1 loop iterations for the lanes that run together.
#ifndef KD_TREE_GLSL
#define KD_TREE_GLSL
#include "bh_fetch.glsl"

#define KD_NO_KEY uvec2(0xFFFFFFFFu, 0xFFFFFFFFu)
#define KD_AXIS_SHIFT 30u
#define KD_INDEX_MASK 0x3FFFFFFFu

uniform usampler2D kd_nodes;

uvec2 kd_heap[KD_K];             // max-heap of the k best keys
uint kd_stack_node[KD_DEPTH];    // far children still to search
uint kd_stack_d2[KD_DEPTH];      // their squared plane distance bits
int kd_sp = 0;
uint kd_node = 0u;               // next node to visit, or KD_N: pop the stack
uint kd_visited = 0u;

bool kd_less(uvec2 a, uvec2 b) {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
}

void kd_init(bool searchable) {
    for (int j = 0; j < KD_K; ++j) {
        kd_heap[j] = KD_NO_KEY;
    }
    kd_sp = 0;
    kd_node = searchable ? 0u : uint(KD_N);
    kd_visited = 0u;
}

// One level of sifting `carry` down from `hole` in the heap kd_heap[0 .. size).
// Returns true when carry has been stored (the sift is over).
bool kd_sift_step(inout int hole, uvec2 carry, int size) {
    int l = 2 * hole + 1;
    int r = l + 1;
    // a missing child reads as the smallest key, so it never moves up
    uvec2 kl = l < size ? kd_heap[min(l, KD_K - 1)] : uvec2(0u);
    uvec2 kr = r < size ? kd_heap[min(r, KD_K - 1)] : uvec2(0u);
    bool right = kd_less(kl, kr);
    uvec2 kc = right ? kr : kl;
    if (kd_less(carry, kc)) {
        kd_heap[hole] = kc;
        hole = right ? r : l;
        return false;
    }
    kd_heap[hole] = carry;
    return true;
}

// Sort kd_heap ascending (heapsort); about k (log2 k + 1) loop iterations.
void kd_heap_sort() {
    for (int end = KD_K - 1; end > 0; --end) {
        uvec2 carry = kd_heap[end];
        kd_heap[end] = kd_heap[0];
        int hole = 0;
        for (;;) {
            if (kd_sift_step(hole, carry, end)) {
                break;
            }
        }
    }
}

// Search from the current state for at most `budget` steps (plus the end of a sift).
// Returns true when the search is complete.
bool kd_search(vec3 q, uint budget) {
    uint steps = 0u;
    bool sifting = false;
    int hole = 0;
    uvec2 carry = KD_NO_KEY;
    bool complete = false;
    for (;;) {
        if (sifting) {
            sifting = !kd_sift_step(hole, carry, KD_K);
        } else if (steps >= budget) {
            break;
        } else if (kd_node < uint(KD_N)) {
            // visit: offer the node's photon, push the far child, go to the near one
            uvec4 t = bh_fetch4(kd_nodes, uint(KD_NODE_W), kd_node);
            vec3 p = uintBitsToFloat(t.xyz);
            precise vec3 d = p - q;
            precise float dd = (d.x * d.x + d.y * d.y) + d.z * d.z;
            uvec2 key = uvec2(floatBitsToUint(dd), t.w & KD_INDEX_MASK);
            kd_visited += 1u;
            if (kd_less(key, kd_heap[0])) {  // replace the k-th best, then sift it down
                carry = key;
                hole = 0;
                sifting = true;
            }
            uint axis = t.w >> KD_AXIS_SHIFT;
            precise float diff = q[axis] - p[axis];
            uint near = 2u * kd_node + (diff < 0.0 ? 1u : 2u);
            uint far = 2u * kd_node + (diff < 0.0 ? 2u : 1u);
            if (far < uint(KD_N)) {
                precise float plane = diff * diff;
                kd_stack_node[kd_sp] = far;
                kd_stack_d2[kd_sp] = floatBitsToUint(plane);
                kd_sp += 1;
            }
            kd_node = near;
        } else if (kd_sp > 0) {
            // pop: search a far child only if it may hold one of the k best (no key yet
            // is 0xFFFFFFFF; non-negative float bits order like the values)
            kd_sp -= 1;
            if (kd_stack_d2[kd_sp] <= kd_heap[0].x) {
                kd_node = kd_stack_node[kd_sp];
            }
        } else {
            complete = true;
            break;
        }
        steps += 1u;
    }
    return complete;
}

#endif
