// kd_query.frag: one fragment per query point, the exact kd-tree kNN shader (paper section 2).
// Takes: kd_queries (RGBA32UI, query i = texel i wrapped row by row at width 2^KD_QUERY_W,
// x, y, z float bits), kd_count (queries in this pass), kd_resume (false: start every
// search; true: continue the state saved by an earlier pass), kd_budget (search steps in
// this pass), and the tree (kd_tree.glsl).
// Returns: query i's k keys at results[i*KD_K ..]: sorted ascending (float32 squared
// distance bits, photon index; 0xFFFFFFFF where missing) when state[2i].w == 1, else the
// unsorted heap of a search to resume; state[2i] = (next node, stack size, nodes visited,
// finished), state[2i+1] = (cell offsets bits, 0) and stack[i*KD_DEPTH ..] = (node, cell
// offsets bits) for resuming.
// Fragment (x, y) of the KD_VIEW_W-wide viewport is query 16 * tile + 4 * (y & 3) + (x & 3)
// with 4 x 4 tiles in row order, so queries given in a spatial order run together.
// A query with NaN or inf gets no neighbours.
// Defines: KD_QUERY_W, KD_VIEW_W, and everything kd_tree.glsl takes.
#include "kd_tree.glsl"

uniform usampler2D kd_queries;
uniform uint kd_count;
uniform bool kd_resume;
uniform uint kd_budget;

layout(std430, binding = 0) buffer Results { uvec2 results[]; };
layout(std430, binding = 1) buffer States { uvec4 state[]; };
layout(std430, binding = 2) buffer Stacks { uvec4 stack[]; };

out vec4 frag_color;

void main() {
    frag_color = vec4(0.0);
    uvec2 px = uvec2(gl_FragCoord.xy);
    uint tile = (px.y >> 2) * uint(KD_VIEW_W / 4) + (px.x >> 2);
    uint i = (tile << 4) | ((px.y & 3u) << 2) | (px.x & 3u);
    if (i >= kd_count) {
        return;
    }
    vec3 q = uintBitsToFloat(bh_fetch4(kd_queries, uint(KD_QUERY_W), i).xyz);
    bool searchable = !(any(isnan(q)) || any(isinf(q)));
    kd_init(q, searchable);
    uint base = i * uint(KD_K);
    uint sbase = i * uint(KD_DEPTH);
    if (kd_resume && searchable) {
        uvec4 s = state[2u * i];
        kd_node = s.x;
        kd_sp = int(s.y);
        kd_visited = s.z;
        kd_off = uintBitsToFloat(state[2u * i + 1u].xyz);
        for (int j = 0; j < KD_K; ++j) {
            kd_heap[j] = results[base + uint(j)];
        }
        for (int j = 0; j < KD_DEPTH; ++j) {
            kd_stack[j] = stack[sbase + uint(j)];
        }
    }
    bool complete = kd_search(q, kd_budget);
    if (!complete) {
        for (int j = 0; j < KD_DEPTH; ++j) {
            stack[sbase + uint(j)] = kd_stack[j];
        }
    }
    for (int j = 0; j < KD_K; ++j) {
        results[base + uint(j)] = kd_heap[j];
    }
    state[2u * i] = uvec4(kd_node, uint(kd_sp), kd_visited, complete ? 1u : 0u);
    state[2u * i + 1u] = uvec4(floatBitsToUint(kd_off), 0u);
}
