// caustic_pass.frag: the caustic pass, one fragment per pixel (paper section 7).
// Takes: shading points per pixel: cp_position (RGBA32F: xyz, material id or -1
// for none; a NaN or infinite position gets no caustic), cp_normal (RGBA32F: unit normal, scalar weight), cp_view (RGBA32F:
// unit direction toward the viewer); a table of up to 16 modified Phong
// materials.  Returns: caustic radiance times the path weight (RGBA32F).
// Defines: CP_GATHER, the gather: CP_COVER (the cover gather, caustic_cover.glsl, and what
// bh_cover.glsl takes), CP_CELLS (the cells lookup, and what bh_cells.glsl takes) or CP_KNN
// (the k nearest by the hash tables or the walk: everything bh_lookup.glsl takes, the
// variant); any other value, or none, fails to compile.  CP_LOOKUP_ONLY (1: run the lookup
// alone and write a value that depends on its result, for timing the pass's stages; with
// BH_FETCH_ONLY, the lookup's fetches alone).
#define CP_COVER 1
#define CP_CELLS 2
#define CP_KNN 3
#if CP_GATHER == CP_COVER
#include "caustic_cover.glsl"
#elif CP_GATHER == CP_CELLS
void caustic_visit(uint s, uint bits);  // caustic_estimate.glsl
#define BH_CELLS_VISIT(s, bits) caustic_visit(s, bits)
#include "bh_cells.glsl"
#elif CP_GATHER == CP_KNN
#include "bh_lookup.glsl"
#else
#error caustic_pass.frag: CP_GATHER must be CP_COVER (1), CP_CELLS (2) or CP_KNN (3)
#endif
#if CP_GATHER != CP_COVER
#include "caustic_estimate.glsl"
#endif

uniform sampler2D cp_position;
uniform sampler2D cp_normal;
uniform sampler2D cp_view;
uniform vec3 cp_kd[16];
uniform vec3 cp_ks[16];
uniform float cp_exponent[16];

out vec4 frag_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 pos = texelFetch(cp_position, px, 0);
    frag_color = vec4(0.0, 0.0, 0.0, 1.0);
    if (pos.w < 0.0 || any(isnan(pos.xyz)) || any(isinf(pos.xyz))) {
        return;  // no surface, or a point that is not finite: no caustic (as on the CPU)
    }
    vec4 nw = texelFetch(cp_normal, px, 0);
    vec3 wo = texelFetch(cp_view, px, 0).xyz;
    int m = int(pos.w);
#if CP_GATHER == CP_COVER && CP_LOOKUP_ONLY
    uvec2 rc = bh_cover_gather(pos.xyz);  // the gather (the floor: its reads) alone
    frag_color = vec4(float(rc.y), float(rc.x), float(bh_cover_sink & 1u), nw.w + wo.x);
    return;
#elif CP_GATHER == CP_CELLS && CP_LOOKUP_ONLY && BH_FETCH_ONLY
    bh_cells_choose(pos.xyz);  // the floor: the candidates read once
    bh_max_bits = 0u;
    bh_max_slot = 0u;
    bh_min_bits = 0u;
    uint examined = bh_cells_pass(BH_PASS_COUNT, pos.xyz, 0u);
    frag_color = vec4(uintBitsToFloat(bh_max_bits), float(examined), 0.0, nw.w + wo.x);
    return;
#elif CP_GATHER == CP_CELLS && CP_LOOKUP_ONLY
    uint examined = bh_cells_select(pos.xyz);
    frag_color = vec4(uintBitsToFloat(bh_top_bits), float(examined), 0.0, nw.w + wo.x);
    return;
#elif CP_LOOKUP_ONLY
    uint examined = bh_lookup(pos.xyz);
    frag_color = vec4(uintBitsToFloat(bh_best[BH_K - 1].x), float(examined),
                      float(bh_fetch_sink & 1u), nw.w + wo.x);
    return;
#endif
#if CP_GATHER == CP_KNN
    bh_lookup(pos.xyz);
#endif
    vec3 l = caustic_radiance(pos.xyz, nw.xyz, wo, cp_kd[m], cp_ks[m], cp_exponent[m]);
    frag_color = vec4(l * nw.w, 1.0);
}
