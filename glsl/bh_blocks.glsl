// bh_blocks.glsl: second dependent fetch, photon blocks (paper 3.2, Figure 4; section 7 step 4).
// Takes: a block reference.  Returns: the block's 64 words (16 RGBA32UI texels)
// and decoded photon positions.  Block b is texels 16b .. 16b+15 of bh_blocks;
// photon j occupies words 6j .. 6j+5, word 60 holds the count.
// Defines: BH_BLK_W (texture width, log2).
#ifndef BH_BLOCKS_GLSL
#define BH_BLOCKS_GLSL
#include "bh_fetch.glsl"
#include "bh_box.glsl"

uniform usampler2D bh_blocks;

#define BH_BLOCK_TEXELS 16
#define BH_COUNT_WORD 60

void bh_fetch_block(uint b, out uvec4 words[BH_BLOCK_TEXELS]) {
    for (int i = 0; i < BH_BLOCK_TEXELS; ++i) {
        words[i] = bh_fetch4(bh_blocks, BH_BLK_W, b * uint(BH_BLOCK_TEXELS) + uint(i));
    }
}

uint bh_word(uvec4 words[BH_BLOCK_TEXELS], uint w) {
    return words[w >> 2u][w & 3u];
}

// Decoded float32 position: lo + float(u) * step, one rounding per operation
// (blockhash/fixedpoint.py Quantizer.decode).
vec3 bh_photon_position(uvec4 words[BH_BLOCK_TEXELS], uint j) {
    uvec3 u = uvec3(bh_word(words, 6u * j), bh_word(words, 6u * j + 1u), bh_word(words, 6u * j + 2u));
    precise vec3 p = bh_lo + vec3(u) * bh_step;
    return p;
}

#endif
