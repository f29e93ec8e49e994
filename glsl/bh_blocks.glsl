// bh_blocks.glsl: second dependent fetch, photon blocks (paper 3.2, Figure 4; section 7 step 4).
// Takes: a block reference.  Returns: its photon count and decoded photon
// positions, fetched word by word from its 16 RGBA32UI texels.  Block b is texels 16b .. 16b+15 of bh_blocks;
// photon j occupies words 6j .. 6j+5, word 60 holds the count.
// Defines: BH_BLK_W (texture width, log2).
#ifndef BH_BLOCKS_GLSL
#define BH_BLOCKS_GLSL
#include "bh_fetch.glsl"
#include "bh_box.glsl"

uniform usampler2D bh_blocks;

#define BH_BLOCK_TEXELS 16
#define BH_COUNT_WORD 60

uint bh_block_count(uint b) {
    return bh_fetch4(bh_blocks, BH_BLK_W, b * uint(BH_BLOCK_TEXELS) + uint(BH_COUNT_WORD >> 2)).x;
}

// Decoded float32 position of photon j: lo + float(u) * step, one rounding per
// operation (blockhash/fixedpoint.py Quantizer.decode).  Its words 6j .. 6j+2
// start at a texel boundary (even j) or half way (odd j): one or two fetches.
vec3 bh_photon_position(uint b, uint j) {
    uint texel = b * uint(BH_BLOCK_TEXELS) + ((6u * j) >> 2u);
    uvec4 a = bh_fetch4(bh_blocks, BH_BLK_W, texel);
    uvec3 u;
    if ((j & 1u) == 0u) {
        u = a.xyz;
    } else {
        u = uvec3(a.zw, bh_fetch4(bh_blocks, BH_BLK_W, texel + 1u).x);
    }
    precise vec3 p = bh_lo + vec3(u) * bh_step;
    return p;
}

#endif
