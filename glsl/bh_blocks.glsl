// bh_blocks.glsl: second dependent fetch, photon blocks (paper 3.2, Figure 4; section 7 step 4).
// Takes: a block reference.  Returns: its photon count and decoded photon
// positions, fetched word by word from its 16 RGBA32UI texels.  Block b is texels 16b .. 16b+15 of bh_blocks;
// photon j occupies words 6j .. 6j+5, word 60 holds the count, words 61-63 the
// block's box in the GL upload (bh_block_head, bh_block_gap2).
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

// Texel 15 of block b: (photon count, box x, box y, box z), the box words as
// blockhash/gl/packing.py block_boxes writes them (lo16 | hi16 << 16 of the codes).
uvec4 bh_block_head(uint b) {
    return bh_fetch4(bh_blocks, BH_BLK_W, b * uint(BH_BLOCK_TEXELS) + uint(BH_COUNT_WORD >> 2));
}

// A lower bound of the float32 squared distance ((dx*dx + dy*dy) + dz*dz) from q to
// every photon of the block whose head is h, or +0.0.  Photon codes lie in
// [lo16 << 16, hi16 << 16 | 0xFFFF]; the bound is decoded like a photon and then
// lowered by 2^-18 of the box's magnitude per axis (far more than the rounding of
// decoding a photon, of float(u) and of this computation) and by 2^-16 relative
// (more than the five roundings of a squared distance).  Every operation rounded on its
// own (precise: nothing fused), as blockhash/index/lookups/hash.py block_gap2 computes it: the
// walk's culling decides which blocks are examined, so both sides must agree bit for bit.
float bh_block_gap2(uvec4 h, vec3 q) {
    precise vec3 lo = bh_lo + vec3(h.yzw << 16u) * bh_step;
    precise vec3 hi = bh_lo + vec3((h.yzw & 0xFFFF0000u) | 0xFFFFu) * bh_step;
    precise vec3 margin = (abs(bh_lo) + bh_step * 4294967296.0) * (1.0 / 262144.0);
    precise vec3 g = max(max(lo - q, q - hi) - margin, vec3(0.0));
    precise float lb = ((g.x * g.x + g.y * g.y) + g.z * g.z) * (1.0 - 1.0 / 65536.0);
    return lb;
}

// Decoded float32 position of photon j: lo + float(u) * step, one rounding per
// operation (blockhash/index/records/fixedpoint.py Quantizer.decode).  Its words 6j .. 6j+2
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
