// bh_fetch.glsl: 1D arrays stored in 2D integer textures, wrapped row by row.
// Takes: a linear element index and the texture's width as log2 (a power of two).
// Returns: the texel.  Layout: element i is texel (i mod W, i div W); see
// blockhash/gl/packing.py.
#ifndef BH_FETCH_GLSL
#define BH_FETCH_GLSL

ivec2 bh_texel(uint index, uint width_log2) {
    return ivec2(int(index & ((1u << width_log2) - 1u)), int(index >> width_log2));
}

uint bh_fetch1(usampler2D tex, uint width_log2, uint index) {
    return texelFetch(tex, bh_texel(index, width_log2), 0).r;
}

uvec2 bh_fetch2(usampler2D tex, uint width_log2, uint index) {
    return texelFetch(tex, bh_texel(index, width_log2), 0).rg;
}

uvec4 bh_fetch4(usampler2D tex, uint width_log2, uint index) {
    return texelFetch(tex, bh_texel(index, width_log2), 0);
}

#endif
