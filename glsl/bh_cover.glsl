// bh_cover.glsl: the cover gather, every photon whose own disc covers the query
// (blockhash/index/lookups/cover.py, its integer-exact CPU reference).  The query's codes give, at
// each octave that holds photons, the cells that hold code +- half on the two coarse axes
// (1 or 2 each) and, on the fine axis, the window of BH_COVER_FINE + 1 fine cells that starts
// at code - half: at most 2 x 2 windows, computed, not searched.  Two dependent rounds: the
// windows' cuckoo slots (bh_cuckoo.glsl, 2 fetches a window), then their records; nothing is
// kept but a sum and one word of flags.
// Takes: a float32 query position.  Calls BH_COVER_VISIT(r, d, d2, h2) (defined by the
// includer) for every covering record r: d = p - q, d2 = |d|^2 < h2, the photon's squared
// radius.  Returns: the records read (uvec2: read, covering).
// Defines: BH_COVER_REC_W, BH_COVER_CELL_W (texture widths, log2), BH_COVER_MASK (cuckoo
// slots - 1), BH_COVER_MAX_OCTAVES (uniform array size), BH_COVER_FINE_AXIS (0, 1, 2: the
// fine axis, cover.py fine_axis); BH_FETCH_ONLY (1: every candidate's first texel read and
// folded into bh_cover_sink, no test: the memory floor).
#ifndef BH_COVER_GLSL
#define BH_COVER_GLSL
#include "bh_box.glsl"
#include "bh_cuckoo.glsl"

uniform usampler2D bh_cover_cells;    // cuckoo slots: (key hi, key lo, first record, count)
uniform usampler2D bh_cover_records;  // 2 texels a record: (x, y, z, h^2 float bits),
                                      // (octahedral wi, octahedral normal, c1 | c2, c3 | c4)
uniform int bh_cover_octaves;         // octaves that hold photons
uniform uvec4 bh_cover_octave[BH_COVER_MAX_OCTAVES];  // (octave, side, half, fine side),
                                                      // finest first

uint bh_cover_sink;

// The first and last cell of one axis holding code +- half, saturated to [0, 2^32).
uvec2 bh_cover_axis(uint code, uint half_, uint side) {
    uint lo = code > half_ ? code - half_ : 0u;
    uint hi = code > 0xFFFFFFFFu - half_ ? 0xFFFFFFFFu : code + half_;
    return uvec2(lo / side, hi / side);
}

// The two key words of window (cx, cy, f) of an octave (cover.py window_key).
uvec2 bh_cover_key(uint level, uint cx, uint cy, uint f) {
    return uvec2((cy >> 11u) | (cx << 7u) | (level << 25u), f | (cy << 21u));
}

uvec2 bh_cover_gather(vec3 q) {
    uvec3 code = bh_quantize(q);
#if BH_COVER_FINE_AXIS == 0
    code = code.yzx;  // (coarse, coarse, fine): cover.py axis_order
#elif BH_COVER_FINE_AXIS == 1
    code = code.xzy;
#endif
    uint read = 0u;
    uint covering = 0u;
    bh_cover_sink = 0u;
    for (int o = 0; o < bh_cover_octaves; ++o) {
        uvec4 oc = bh_cover_octave[o];
        uvec2 xs = bh_cover_axis(code.x, oc.z, oc.y);
        uvec2 ys = bh_cover_axis(code.y, oc.z, oc.y);
        uint f = bh_cover_axis(code.z, oc.z, oc.w).x;
        for (uint c = 0u; c < 4u; ++c) {
            uint cx = xs.x + (c >> 1u);
            uint cy = ys.x + (c & 1u);
            if (cx > xs.y || cy > ys.y) {
                continue;  // one cell on that axis
            }
            uvec2 key = bh_cover_key(oc.x, cx, cy, f);
            uvec2 run = bh_cuckoo(bh_cover_cells, uint(BH_COVER_CELL_W), uint(BH_COVER_MASK),
                                  key.x, key.y);
            read += run.y;
            // The run in chunks of 32: a branch-free pass sets a bit per covering record,
            // then only the set bits are visited.  A SIMD group (llvmpipe's lanes, a GPU's
            // wave) then runs the estimate as often as its busiest lane has covering photons,
            // not once for every candidate where any lane has one.
            for (uint base = run.x; base < run.x + run.y; base += 32u) {
                uint n = min(run.x + run.y - base, 32u);
                uint bits = 0u;
                for (uint i = 0u; i < n; ++i) {
                    uvec4 t0 = bh_fetch4(bh_cover_records, uint(BH_COVER_REC_W), 2u * (base + i));
#if BH_FETCH_ONLY
                    bh_cover_sink ^= t0.x ^ t0.w;
#else
                    precise vec3 d = uintBitsToFloat(t0.xyz) - q;
                    precise float d2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
                    bits |= uint(d2 < uintBitsToFloat(t0.w)) << i;
#endif
                }
                covering += uint(bitCount(bits));
                while (bits != 0u) {
                    uint r = base + uint(findLSB(bits));
                    bits &= bits - 1u;
                    // The first texel again (a cache hit), not kept from the pass above: no
                    // per-chunk list in registers or scratch.
                    uvec4 t0 = bh_fetch4(bh_cover_records, uint(BH_COVER_REC_W), 2u * r);
                    precise vec3 d = uintBitsToFloat(t0.xyz) - q;
                    precise float d2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
                    BH_COVER_VISIT(r, d, d2, uintBitsToFloat(t0.w));
                }
            }
        }
    }
    return uvec2(read, covering);
}

#endif
