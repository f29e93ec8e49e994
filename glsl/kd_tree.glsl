// kd_tree.glsl: exact k nearest photons by a balanced kd-tree search (paper section 2,
// the exact baseline that Block Hashing is compared with).
// Takes: a float32 query; the photons' bounding box kd_lo, kd_hi (the root's cell); the
// tree in kd_nodes (RGBA32UI, node i = texel i wrapped row by row: x, y, z float bits and
// photon index | split axis << 30), a heap-ordered complete tree: node i has children
// 2i+1 and 2i+2 where those are below KD_N (blockhash/gl/kdtree.py).
// Returns: the k best keys (float32 squared distance bits, photon index) in kd_heap, sorted
// ascending when the search finished; while it runs kd_heap is a max-heap whose top
// kd_heap[0] is the k-th nearest, the pruning radius.  Also the nodes visited.
// Defines: KD_K (k), KD_LEVELS (floor(log2 KD_K)), KD_N (nodes), KD_DEPTH (tree height =
// stack size), KD_NODE_W (log2 width of kd_nodes).
//
// Exactness: distances are ((dx*dx + dy*dy) + dz*dz) in float32 with d = p - q, as in
// bh_lookup.glsl.  A node is skipped with its subtree only when the float32 squared
// distance to its cell, computed with the same operations from per-axis offsets that
// are float32 lower bounds of |p - q| (rounding is monotonic), exceeds the k-th
// distance; so the result is the float32 brute force on (distance, index) keys.
//
// llvmpipe stops every loop of a shader invocation once 65,535 loop iterations have run
// in total (gallivm's shared loop limiter; loops of up to 32 constant iterations are
// unrolled and do not count), silently.  So the search is one loop of steps (pop if
// needed, visit one node) that stops itself after a step budget with its whole state in
// kd_node, kd_off, kd_sp, kd_stack, kd_heap, kd_visited: the caller saves it and resumes in
// a later pass.  The lanes that run together spend at most budget + k loop iterations.
#ifndef KD_TREE_GLSL
#define KD_TREE_GLSL
#include "bh_fetch.glsl"

#define KD_NO_KEY uvec2(0xFFFFFFFFu, 0xFFFFFFFFu)
#define KD_AXIS_SHIFT 30u
#define KD_INDEX_MASK 0x3FFFFFFFu

uniform usampler2D kd_nodes;
uniform vec3 kd_lo;              // bounding box of the photons: the root's cell
uniform vec3 kd_hi;

uvec2 kd_heap[KD_K];             // max-heap of the k best keys
uvec4 kd_stack[KD_DEPTH];        // far children still to search: node, cell offsets bits
int kd_sp = 0;
uint kd_node = 0u;               // next node to visit, or KD_N: pop the stack
vec3 kd_off = vec3(0.0);         // per-axis distance from the query to kd_node's cell
uint kd_visited = 0u;

bool kd_less(uvec2 a, uvec2 b) {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
}

void kd_init(vec3 q, bool searchable) {
    for (int j = 0; j < KD_K; ++j) {
        kd_heap[j] = KD_NO_KEY;
    }
    kd_sp = 0;
    precise vec3 below = kd_lo - q;
    precise vec3 above = q - kd_hi;
    kd_off = max(max(below, above), vec3(0.0));
    kd_node = searchable ? 0u : uint(KD_N);
    kd_visited = 0u;
}

// Store `carry` in the root of the heap kd_heap[0 .. size) and sift it down.  A loop
// of KD_LEVELS = floor(log2 KD_K) constant iterations: the compiler unrolls it, so it
// spends none of llvmpipe's loop budget.
void kd_sift(uvec2 carry, int size) {
    int hole = 0;
    bool placed = false;
    for (int level = 0; level < KD_LEVELS; ++level) {
        int l = 2 * hole + 1;
        int r = l + 1;
        // a missing child reads as the smallest key, so it never moves up
        uvec2 kl = l < size ? kd_heap[min(l, KD_K - 1)] : uvec2(0u);
        uvec2 kr = r < size ? kd_heap[min(r, KD_K - 1)] : uvec2(0u);
        bool right = kd_less(kl, kr);
        uvec2 kc = right ? kr : kl;
        placed = placed || !kd_less(carry, kc);
        if (!placed) {
            kd_heap[hole] = kc;
            hole = right ? r : l;
        }
    }
    kd_heap[hole] = carry;
}

// Squared distance from the query to a cell whose per-axis offsets from it are `off`,
// rounded exactly as the photon distances are, so it is a lower bound of every float32
// photon distance in the cell (rounding is monotonic).
float kd_cell_d2(vec3 off) {
    precise float b = (off.x * off.x + off.y * off.y) + off.z * off.z;
    return b;
}

// Search from the current state for at most `budget` steps, then sort the k best.
// A step pops the stack when the descent is over, then visits one node: a node whose
// cell lies farther than the k-th distance is skipped with its subtree (incremental
// cell distance, Arya & Mount), else its photon replaces the k-th best if nearer, its far
// child is pushed with the cell offsets updated on the split axis (unless that cell is
// already too far; it is checked again when popped), and the descent goes on to the near
// child.  Once the search is complete the same loop heapsorts kd_heap ascending (k - 1
// more iterations; one kd_sift in the loop body serves both, which halves the compile
// time).  Returns true when the search is complete and kd_heap sorted; false when the
// budget ran out first (kd_heap is then the heap, to be resumed).
bool kd_search(vec3 q, uint budget) {
    uint steps = 0u;
    int end = KD_K;  // heapsort: kd_heap[0 .. end) is the heap, kd_heap[end ..) sorted
    for (;;) {
        bool sift = false;
        uvec2 carry = KD_NO_KEY;
        int size = KD_K;
        if (kd_node >= uint(KD_N) && kd_sp == 0) {
            if (end <= 1) {
                return true;
            }
            end -= 1;  // move the largest key behind the heap, sift the displaced one
            carry = kd_heap[end];
            kd_heap[end] = kd_heap[0];
            size = end;
            sift = true;
        } else if (steps >= budget) {
            return false;
        } else {
            steps += 1u;
            if (kd_node >= uint(KD_N)) {
                kd_sp -= 1;
                uvec4 e = kd_stack[kd_sp];
                kd_node = e.x;
                kd_off = uintBitsToFloat(e.yzw);
            }
            // non-negative float bits order like the values; no key yet is 0xFFFFFFFF
            if (floatBitsToUint(kd_cell_d2(kd_off)) > kd_heap[0].x) {
                kd_node = uint(KD_N);
            } else {
                uvec4 t = bh_fetch4(kd_nodes, uint(KD_NODE_W), kd_node);
                vec3 p = uintBitsToFloat(t.xyz);
                precise vec3 d = p - q;
                precise float dd = (d.x * d.x + d.y * d.y) + d.z * d.z;
                carry = uvec2(floatBitsToUint(dd), t.w & KD_INDEX_MASK);
                sift = kd_less(carry, kd_heap[0]);  // replaces the k-th best
                kd_visited += 1u;
                uint axis = t.w >> KD_AXIS_SHIFT;
                precise float diff = q[axis] - p[axis];
                uint near = 2u * kd_node + (diff < 0.0 ? 1u : 2u);
                uint far = 2u * kd_node + (diff < 0.0 ? 2u : 1u);
                vec3 off = kd_off;
                off[axis] = max(off[axis], abs(diff));
                if (far < uint(KD_N) && floatBitsToUint(kd_cell_d2(off)) <= kd_heap[0].x) {
                    kd_stack[kd_sp] = uvec4(far, floatBitsToUint(off));
                    kd_sp += 1;
                }
                kd_node = near;
            }
        }
        if (sift) {
            kd_sift(carry, size);
        }
    }
    return false;  // not reached
}

#endif
