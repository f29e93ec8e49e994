// kd_query.frag: one fragment per query point, the exact kd-tree kNN shader (paper section 2).
// Takes: kd_queries (RGBA32UI, one point per texel as float bits, row-major over the
// viewport of width KD_QUERY_W), kd_queries_n (queries in this pass) and the tree
// (kd_tree.glsl).
// Returns: for query i, BH_K (squared-distance bits, photon index) pairs at
// results[i * BH_K ...], ascending (index 0xFFFFFFFF where missing), and the nodes
// visited at visits[i]; a query with NaN or inf gets no neighbours.
// Defines: KD_QUERY_W, and everything kd_tree.glsl takes.
#include "kd_tree.glsl"

uniform usampler2D kd_queries;
uniform uint kd_queries_n;

layout(std430, binding = 0) writeonly buffer Results { uvec2 results[]; };
layout(std430, binding = 1) writeonly buffer Visits { uint visits[]; };

out vec4 frag_color;

void main() {
    uint i = uint(gl_FragCoord.y) * uint(KD_QUERY_W) + uint(gl_FragCoord.x);
    frag_color = vec4(0.0);
    if (i >= kd_queries_n) {
        return;
    }
    vec3 q = uintBitsToFloat(texelFetch(kd_queries, ivec2(gl_FragCoord.xy), 0).xyz);
    uint visited = 0u;
    if (any(isnan(q)) || any(isinf(q))) {
        bh_select_init();
    } else {
        visited = kd_search(q);
    }
    for (int j = 0; j < BH_K; ++j) {
        results[i * uint(BH_K) + uint(j)] = bh_best[j];
    }
    visits[i] = visited;
}
