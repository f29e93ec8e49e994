// bh_cuckoo.glsl: the cuckoo hash of cell keys (blockhash/index/lookups/cells.py cell_hash,
// cuckoo_get): a key sits in one of the two slots its two hash functions name, so a
// lookup is 2 independent texel fetches and no probe sequence.
// Takes: the table's texture, its width (log2), slots - 1, and the key's two words.
// Returns: the key's (first, count), (0, 0) when it is not stored.
#ifndef BH_CUCKOO_GLSL
#define BH_CUCKOO_GLSL
#include "bh_fetch.glsl"

// MurmurHash3's 32-bit finaliser (cells.py fmix32).
uint bh_fmix(uint x) {
    x ^= x >> 16u;
    x *= 0x85EBCA6Bu;
    x ^= x >> 13u;
    x *= 0xC2B2AE35u;
    x ^= x >> 16u;
    return x;
}

uvec2 bh_cuckoo(usampler2D table, uint width_log2, uint mask, uint hi, uint lo) {
    uvec4 a = bh_fetch4(table, width_log2, bh_fmix(lo ^ bh_fmix(hi ^ 0x9E3779B9u)) & mask);
    uvec4 b = bh_fetch4(table, width_log2, bh_fmix(lo ^ bh_fmix(hi ^ 0x7F4A7C15u)) & mask);
    return (a.x == hi && a.y == lo) ? a.zw : ((b.x == hi && b.y == lo) ? b.zw : uvec2(0u));
}

// The two key words of cell (cx, cy, cz) (each below 2^19) of level (cells.py cell_key).
uvec2 bh_cell_key(uint level, uvec3 c) {
    return uvec2((c.y >> 13u) | (c.x << 6u) | (level << 25u), c.z | (c.y << 19u));
}

#endif
