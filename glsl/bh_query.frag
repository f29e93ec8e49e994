// bh_query.frag: one fragment per query point, the lookup API's shader.
// Takes: bh_queries (RGBA32F, one point per texel, row-major over the viewport).
// Returns: for query i, BH_K (squared-distance bits, slot) pairs at
// results[i * BH_K ...] and the candidates examined at counts[i]; a query with
// NaN or inf gets no neighbours (with BH_FETCH_ONLY, counts[] gets the
// candidates plus one bit of the fetched data), and the blocks culled at culled[i].  Uniforms: bh_query_w (viewport
// width), bh_queries_n (queries in this pass): a new image size needs no new program.
// Defines: everything bh_lookup.glsl takes.
layout(std430, binding = 0) writeonly buffer Results { uvec2 results[]; };
#if BH_CELLS
// The cell lookup (bh_cells.glsl) writes the k it selects in the order it meets them; the
// caller sorts them (GLLookup.query).
#define BH_CELLS_EMIT(i, key) results[i] = key
#include "bh_cells.glsl"
#else
#include "bh_lookup.glsl"
#endif

uniform sampler2D bh_queries;
uniform uint bh_query_w;    // viewport width: query i is pixel (i mod w, i div w)
uniform uint bh_queries_n;  // queries in this pass

layout(std430, binding = 1) writeonly buffer Counts { uint counts[]; };
layout(std430, binding = 2) writeonly buffer Culled { uint culled[]; };  // blocks culled

out vec4 frag_color;

void main() {
    uint i = uint(gl_FragCoord.y) * bh_query_w + uint(gl_FragCoord.x);
    frag_color = vec4(0.0);
    if (i >= bh_queries_n) {
        return;
    }
    vec3 q = texelFetch(bh_queries, ivec2(gl_FragCoord.xy), 0).xyz;
    uint examined = 0u;
#if BH_CELLS
    uint base = i * uint(BH_K);
    bh_emitted = 0u;
    if (!(any(isnan(q)) || any(isinf(q)))) {
#if BH_FETCH_ONLY
        // The memory floor: the same candidates read once, nothing selected.
        bh_cells_choose(q);
        bh_max_bits = 0u;
        bh_max_slot = 0u;
        bh_min_bits = 0u;
        examined = bh_cells_pass(BH_PASS_COUNT, q, 0u) + (bh_max_bits & 1u);
#else
        examined = bh_cells_select(q);
        bh_cells_pass(BH_PASS_EMIT, q, base);
#endif
    }
    for (uint j = bh_emitted; j < uint(BH_K); ++j) {
        results[base + j] = uvec2(0x7F800000u, 0xFFFFFFFFu);
    }
    counts[i] = examined;
    culled[i] = 0u;
#else
    if (any(isnan(q)) || any(isinf(q))) {
        bh_select_init();
    } else {
        examined = bh_lookup(q);
    }
    for (int j = 0; j < BH_K; ++j) {
        results[i * uint(BH_K) + uint(j)] = bh_best[j];
    }
#if BH_FETCH_ONLY
    counts[i] = examined + (bh_fetch_sink & 1u);  // keeps the fetches alive
#else
    counts[i] = examined;
#endif
    culled[i] = bh_culled;
#endif
}
