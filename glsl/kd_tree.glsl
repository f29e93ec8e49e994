// kd_tree.glsl: exact k nearest photons by a balanced kd-tree search (paper section 2,
// the baseline Block Hashing is compared with).
// Takes: a float32 query position; the tree in kd_nodes (RGBA32UI, node i = texel i
// wrapped row by row: x, y, z float bits and photon index | split axis << 30), stored
// as a heap: node i has children 2i+1 and 2i+2 where those are below KD_N (a
// left-balanced tree, blockhash/gl/kdtree.py).
// Returns: the k nearest photons in bh_best, ascending keys (float32 squared distance
// bits, original photon index), and the number of nodes visited.
// Defines: KD_N (nodes), KD_DEPTH (tree height = stack size), KD_NODE_W (log2 width of
// kd_nodes), and BH_K, BH_SELECT for the k-best list (bh_select.glsl).
// The search is exact: a far child is skipped only when its squared plane distance
// (float32, a lower bound of every float32 distance below it) exceeds the current
// k-th distance, so the result equals the float32 brute force on (distance, index) keys.
#ifndef KD_TREE_GLSL
#define KD_TREE_GLSL
#include "bh_variants.glsl"
#include "bh_fetch.glsl"
#include "bh_select.glsl"

#define KD_AXIS_SHIFT 30u
#define KD_INDEX_MASK 0x3FFFFFFFu

uniform usampler2D kd_nodes;

uint kd_search(vec3 q) {
    bh_select_init();
    uint stack_node[KD_DEPTH];
    uint stack_d2[KD_DEPTH];  // squared plane distance bits of the pushed far child
    int sp = 0;
    uint node = 0u;
    uint visited = 0u;
    for (;;) {
        // descend from `node` to a leaf, always to the query's side, pushing far children
        while (node < uint(KD_N)) {
            uvec4 t = bh_fetch4(kd_nodes, uint(KD_NODE_W), node);
            vec3 p = uintBitsToFloat(t.xyz);
            precise vec3 d = p - q;
            precise float dd = (d.x * d.x + d.y * d.y) + d.z * d.z;
            uint index = t.w & KD_INDEX_MASK;
            bh_select_offer(uvec2(floatBitsToUint(dd), index));
            visited += 1u;
            uint axis = t.w >> KD_AXIS_SHIFT;
            precise float diff = q[axis] - p[axis];
            uint near = 2u * node + (diff < 0.0 ? 1u : 2u);
            uint far = 2u * node + (diff < 0.0 ? 2u : 1u);
            if (far < uint(KD_N)) {
                precise float plane = diff * diff;
                stack_node[sp] = far;
                stack_d2[sp] = floatBitsToUint(plane);
                sp += 1;
            }
            node = near;
        }
        // pop the next far child that may still hold one of the k best
        // (non-negative float bits order like the values; no key yet = 0xFFFFFFFF)
        bool found = false;
        while (sp > 0) {
            sp -= 1;
            if (stack_d2[sp] <= bh_best[BH_K - 1].x) {
                node = stack_node[sp];
                found = true;
                break;
            }
        }
        if (!found) {
            break;
        }
    }
    return visited;
}

#endif
