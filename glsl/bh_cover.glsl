// bh_cover.glsl: the cover gather, every photon whose own disc covers the query
// (blockhash/index/lookups/cover.py, its integer-exact CPU reference).  The query's codes give, at
// each octave that holds photons, the cells that hold code +- half on each axis (at most
// 2 x 2 x 2), computed, not searched.  Two dependent rounds: the cells' cuckoo slots
// (bh_cuckoo.glsl, 2 fetches a cell), then their records; nothing is kept but a sum.
// Takes: a float32 query position.  Calls BH_COVER_VISIT(r, d, d2, h2) (defined by the
// includer) for every covering record r: d = p - q, d2 = |d|^2 < h2, the photon's squared
// radius.  Returns: the records read (uvec2: read, covering).
// Defines: BH_COVER_REC_W, BH_COVER_CELL_W (texture widths, log2), BH_COVER_MASK (cuckoo
// slots - 1), BH_COVER_MAX_OCTAVES (uniform array size); BH_FETCH_ONLY (1: every candidate's
// first texel read and folded into bh_cover_sink, no test: the memory floor).
#ifndef BH_COVER_GLSL
#define BH_COVER_GLSL
#include "bh_box.glsl"
#include "bh_cuckoo.glsl"

uniform usampler2D bh_cover_cells;    // cuckoo slots: (key hi, key lo, first record, count)
uniform usampler2D bh_cover_records;  // 2 texels a record: (x, y, z, h^2 float bits),
                                      // (octahedral wi, octahedral normal, c1 | c2, c3 | c4)
uniform int bh_cover_octaves;         // octaves that hold photons
uniform uvec4 bh_cover_octave[BH_COVER_MAX_OCTAVES];  // (octave, side, half, 0), finest first

uint bh_cover_sink;

// The first and last cell of one axis holding code +- half, saturated to [0, 2^32).
uvec2 bh_cover_axis(uint code, uint half_, uint side) {
    uint lo = code > half_ ? code - half_ : 0u;
    uint hi = code > 0xFFFFFFFFu - half_ ? 0xFFFFFFFFu : code + half_;
    return uvec2(lo / side, hi / side);
}

uvec2 bh_cover_gather(vec3 q) {
    uvec3 code = bh_quantize(q);
    uint read = 0u;
    uint covering = 0u;
    bh_cover_sink = 0u;
    for (int o = 0; o < bh_cover_octaves; ++o) {
        uvec4 oc = bh_cover_octave[o];
        uvec2 xs = bh_cover_axis(code.x, oc.z, oc.y);
        uvec2 ys = bh_cover_axis(code.y, oc.z, oc.y);
        uvec2 zs = bh_cover_axis(code.z, oc.z, oc.y);
        for (uint c = 0u; c < 8u; ++c) {
            uvec3 cell = uvec3(xs.x + (c >> 2u), ys.x + ((c >> 1u) & 1u), zs.x + (c & 1u));
            if (cell.x > xs.y || cell.y > ys.y || cell.z > zs.y) {
                continue;  // one cell on that axis
            }
            uvec2 key = bh_cell_key(oc.x, cell);
            uvec2 run = bh_cuckoo(bh_cover_cells, uint(BH_COVER_CELL_W), uint(BH_COVER_MASK),
                                  key.x, key.y);
            read += run.y;
            for (uint r = run.x; r < run.x + run.y; ++r) {
                uvec4 t0 = bh_fetch4(bh_cover_records, uint(BH_COVER_REC_W), 2u * r);
#if BH_FETCH_ONLY
                bh_cover_sink ^= t0.x ^ t0.w;
#else
                precise vec3 d = uintBitsToFloat(t0.xyz) - q;
                precise float d2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
                float h2 = uintBitsToFloat(t0.w);
                if (d2 < h2) {
                    covering += 1u;
                    BH_COVER_VISIT(r, d, d2, h2);
                }
#endif
            }
        }
    }
    return uvec2(read, covering);
}

#endif
