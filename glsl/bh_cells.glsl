// bh_cells.glsl: the cell lookup (lookup='cells'), Hilbert cells in a cuckoo hash (blockhash/index/lookups/cells.py,
// the CPU oracle blockhash/index/lookups/cells_query.py).  Three rounds of fetches, each independent
// within itself: the query's own cell at every level above BH_CELL_FIRST (2 fetches a
// cell), the 3 x 3 x 3 groups at three levels (162 fetches), the chosen group's photons
// (one RGBA32F texel each).  Then the k nearest candidates are found by counting: passes
// over the same candidates, read again from cache, narrow a bracket of (squared-distance
// bits, slot) keys eight ways until exactly k keys lie at or below it (at most 11 passes on
// the distance bits, then 11 on the slots of equal distances; typically 3 or 4 in all).  No list of k is
// kept: the registers hold the bracket, seven split keys and seven counters.
// Takes: a float32 query position.  Returns (bh_cells_select): the number of candidates and
// the bracket's top key (bh_top_bits, bh_top_slot); bh_cells_pass then visits the selected
// candidates again (BH_PASS_EMIT writes them, BH_PASS_MAX finds the k-th).
// Defines: BH_K, BH_CAP (= A * k), BH_CELL_W and BH_PT_W (texture widths, log2),
// BH_CELL_MASK (slots - 1), BH_CELL_FIRST (CellTable.first_level(A * k)).
#ifndef BH_CELLS_GLSL
#define BH_CELLS_GLSL
#include "bh_fetch.glsl"
#include "bh_box.glsl"
#include "bh_cuckoo.glsl"

uniform usampler2D bh_cells;  // cuckoo slots: (key hi, key lo, first slot, count)
uniform sampler2D bh_points;  // decoded photon positions by slot (w: unused)
uniform int bh_group_cells;   // 27; a uniform bound keeps the cell loop rolled

#define BH_CODE_SHIFT 11u
#define BH_LEVEL_MIN 2
#define BH_LEVEL_TOP 21
#define BH_SPLITS 7  // split keys per counting pass: an eight-way narrowing
#define BH_MAX_PASSES 11  // per phase: 8^11 > 2^32
#define BH_PASS_COUNT 0
#define BH_PASS_EMIT 1
#define BH_PASS_MAX 2
#define BH_PASS_VISIT 3

// The cells of a group in shell order (cell_query.py SHELL_ORDER).
const int bh_shell[27] = int[27](13, 4, 10, 12, 14, 16, 22, 1, 3, 5, 7, 9, 11, 15, 17, 19, 21, 23,
                                 25, 0, 2, 6, 8, 18, 20, 24, 26);

// (first slot, count) of cell c of level, (0, 0) outside the grid or not stored.
uvec2 bh_cell(int level, ivec3 c) {
    int side = 1 << (BH_LEVEL_TOP - level);
    if (any(lessThan(c, ivec3(0))) || any(greaterThanEqual(c, ivec3(side)))) {
        return uvec2(0u);
    }
    uvec2 key = bh_cell_key(uint(level), uvec3(c));
    return bh_cuckoo(bh_cells, uint(BH_CELL_W), uint(BH_CELL_MASK), key.x, key.y);
}

ivec3 bh_group_offset(int j) {
    return ivec3(j % 3, (j / 3) % 3, j / 9) - 1;
}

uint bh_group_total(int level, ivec3 own) {
    uint total = 0u;
    for (int j = 0; j < 27; ++j) {
        total += bh_cell(level, own + bh_group_offset(j)).y;
    }
    return total;
}

// The chosen group: its level and the query's own cell there.
int bh_level;
ivec3 bh_own;
uint bh_total;  // the chosen group's photons
uint bh_top_bits;  // the bracket's top key: the selected candidates are those at or below it
uint bh_top_slot;

void bh_cells_choose(vec3 q) {
    precise vec3 t = (q - bh_lo) * bh_inv_step;
    t = min(max(t, vec3(0.0)), vec3(4294967040.0));  // largest float32 below 2^32
    ivec3 c0 = ivec3(uvec3(t) >> BH_CODE_SHIFT);
    // Round 1: own cells above BH_CELL_FIRST; their counts grow with the level.
    int top = BH_CELL_FIRST;
    for (int level = BH_CELL_FIRST + 1; level <= BH_LEVEL_TOP; ++level) {
        top = (bh_cell(level, c0 >> level).y <= uint(BH_CAP)) ? level : top;
    }
    // Round 2: the groups at top - 2, top - 1, top (cell_query.py TRIED).
    int lev[3];
    uint tot[3];
    for (int i = 0; i < 3; ++i) {
        lev[i] = clamp(top + i - 2, BH_LEVEL_MIN, BH_LEVEL_TOP);
        tot[i] = bh_group_total(lev[i], c0 >> lev[i]);
    }
    int pick = -1;
    for (int i = 0; i < 3; ++i) {
        pick = (tot[i] >= uint(BH_K) && tot[i] <= uint(BH_CAP)) ? i : pick;
    }
    int finest = -1;  // failing that, the finest holding at least k
    for (int i = 2; i >= 0; --i) {
        finest = tot[i] >= uint(BH_K) ? i : finest;
    }
    pick = pick < 0 ? finest : pick;
    pick = pick < 0 ? 2 : pick;
    bh_level = pick == 0 ? lev[0] : (pick == 1 ? lev[1] : lev[2]);
    bh_total = pick == 0 ? tot[0] : (pick == 1 ? tot[1] : tot[2]);
    bh_own = c0 >> bh_level;
}

float bh_point_d2(uint s, vec3 q) {
    vec3 p = texelFetch(bh_points, bh_texel(s, uint(BH_PT_W)), 0).xyz;
    precise vec3 d = p - q;
    precise float dd = (d.x * d.x + d.y * d.y) + d.z * d.z;
    return dd;
}

// Split keys and their counts of the current counting pass.
uint bh_sb[BH_SPLITS];
uint bh_ss[BH_SPLITS];
uint bh_sc[BH_SPLITS];
// The photon slot and squared distance of the candidate bh_cells_visit is given.
uint bh_max_bits;
uint bh_max_slot;
uint bh_emitted;
uint bh_min_bits;

// One pass over the candidates (round 3's photons, cut at the cap), in the order the CPU
// takes them.  Returns the candidates.  mode: BH_PASS_COUNT counts keys at or below each
// split key and finds the largest key; BH_PASS_EMIT writes the selected (key at or below
// the top) with BH_CELLS_EMIT(index, key) from base on; BH_PASS_MAX finds the largest
// selected key; BH_PASS_VISIT calls BH_CELLS_VISIT(slot, bits) for each selected (both
// macros defined by the includer).
uint bh_cells_pass(int mode, vec3 q, uint base) {
    uint taken = 0u;
    for (int oj = 0; oj < bh_group_cells; ++oj) {
        uvec2 fc = bh_cell(bh_level, bh_own + bh_group_offset(bh_shell[oj]));
        uint n = min(fc.y, uint(BH_CAP) - taken);
        uint f = fc.x;
        uint e = f + n;
        for (uint s0 = f; s0 < e; s0 += 4u) {
            for (int u = 0; u < 4; ++u) {
                uint s = s0 + uint(u);
                if (s < e) {
                    uint bits = floatBitsToUint(bh_point_d2(s, q));
                    if (mode == BH_PASS_COUNT) {
                        for (int i = 0; i < BH_SPLITS; ++i) {
                            bh_sc[i] += uint(bits < bh_sb[i] || (bits == bh_sb[i] && s <= bh_ss[i]));
                        }
                        bool more = bits > bh_max_bits || (bits == bh_max_bits && s > bh_max_slot);
                        bh_max_bits = more ? bits : bh_max_bits;
                        bh_max_slot = more ? s : bh_max_slot;
                        bh_min_bits = min(bh_min_bits, bits);
                    } else {
                        bool sel = bits < bh_top_bits || (bits == bh_top_bits && s <= bh_top_slot);
#ifdef BH_CELLS_EMIT
                        if (mode == BH_PASS_EMIT && sel) {
                            BH_CELLS_EMIT(base + bh_emitted, uvec2(bits, s));
                            bh_emitted += 1u;
                        }
#endif
#ifdef BH_CELLS_VISIT
                        if (mode == BH_PASS_VISIT && sel) {
                            BH_CELLS_VISIT(s, bits);
                        }
#endif
                        bool more = sel && (bits > bh_max_bits || (bits == bh_max_bits && s > bh_max_slot));
                        bh_max_bits = more ? bits : bh_max_bits;
                        bh_max_slot = more ? s : bh_max_slot;
                    }
                }
            }
        }
        taken += n;
    }
    return taken;
}

// Split point i (0 .. 6) of an integer bracket (lo, hi] (lo_none: it starts at 0
// inclusive), inside it and increasing with i: every pass cuts the bracket to an eighth
// or less, so a 32-bit bracket closes within BH_MAX_PASSES = 11 passes.
uint bh_split(bool lo_none, uint lo, uint hi, int i) {
    uint base = lo_none ? 0u : lo + 1u;  // the smallest value inside
    uint span = hi - base;               // values inside, less one
    return min(base + max(span >> 3u, 1u) * uint(i + 1) - 1u, hi);
}

// One step of a bracket search over the split values v (bh_sb or bh_ss) and their counts
// bh_sc: the first split holding at least k keys becomes hi (top_count its count), the
// splits before it, holding fewer, move lo up to the last of them.
void bh_narrow(uint v[BH_SPLITS], inout bool lo_none, inout uint lo, inout uint hi,
               inout uint top_count) {
    bool found = false;
    for (int i = 0; i < BH_SPLITS; ++i) {
        bool hit = !found && bh_sc[i] >= uint(BH_K) && v[i] < hi;
        bool below = !found && bh_sc[i] < uint(BH_K) && (lo_none || v[i] > lo);
        hi = hit ? v[i] : hi;
        top_count = hit ? bh_sc[i] : top_count;
        lo = below ? v[i] : lo;
        lo_none = below ? false : lo_none;
        found = found || hit;
    }
}

// Choose the group, then find the k-th key by counting: first the distance bits D of the
// k-th (the least D with at least k keys of bits <= D), then, where several candidates sit
// at D, the slot.  Afterwards the selected candidates are exactly those with a key at or
// below (bh_top_bits, bh_top_slot): k of them, or all when there are at most k.
// Returns the candidates.
uint bh_cells_select(vec3 q) {
    bh_cells_choose(q);
    // The first pass's splits: a guess of the k-th squared distance from the group (k of
    // its photons in 3 x 3 x 3 cells of side h: 3 h^2 k / photons), times 2^-3 .. 2^3.
    float h = bh_step.x * float(1u << (BH_CODE_SHIFT + uint(bh_level)));
    float guess = 3.0 * h * h * float(BH_K) / float(max(min(bh_total, uint(BH_CAP)), 1u));
    for (int i = 0; i < BH_SPLITS; ++i) {
        bh_sb[i] = floatBitsToUint(guess * exp2(float(i - 3)));
        bh_ss[i] = 0xFFFFFFFFu;
        bh_sc[i] = 0u;
    }
    bh_max_bits = 0u;
    bh_max_slot = 0u;
    bh_min_bits = 0xFFFFFFFFu;
    uint m = bh_cells_pass(BH_PASS_COUNT, q, 0u);
    bh_top_bits = bh_max_bits;
    bh_top_slot = bh_max_slot;
    uint top_count = m;
    // Phase 1 over distance bits: count(bits <= lo) < k <= count(bits <= hi), from just
    // below the nearest candidate to the farthest, narrowed by the first pass's splits and
    // then by splits inside the bracket.
    bool lo_none = bh_min_bits == 0u;
    uint lo = lo_none ? 0u : bh_min_bits - 1u;
    uint hi = bh_max_bits;
    for (int pass = 0; pass <= BH_MAX_PASSES && top_count > uint(BH_K) &&
                       !(!lo_none && hi == lo + 1u) && !(lo_none && hi == 0u); ++pass) {
        if (pass > 0) {
            for (int i = 0; i < BH_SPLITS; ++i) {
                bh_sb[i] = bh_split(lo_none, lo, hi, i);
                bh_ss[i] = 0xFFFFFFFFu;
                bh_sc[i] = 0u;
            }
            bh_cells_pass(BH_PASS_COUNT, q, 0u);
        }
        bh_narrow(bh_sb, lo_none, lo, hi, top_count);
        bh_top_bits = hi;
        bh_top_slot = hi == bh_max_bits ? bh_max_slot : 0xFFFFFFFFu;
    }
    // Phase 2, ties at D = hi: find the slot.
    bool slo_none = true;
    uint slo = 0u;
    uint shi = bh_top_slot;
    for (int pass = 0; pass < BH_MAX_PASSES && top_count > uint(BH_K) &&
                       !(!slo_none && shi == slo + 1u) && !(slo_none && shi == 0u); ++pass) {
        for (int i = 0; i < BH_SPLITS; ++i) {
            bh_sb[i] = bh_top_bits;
            bh_ss[i] = bh_split(slo_none, slo, shi, i);
            bh_sc[i] = 0u;
        }
        bh_cells_pass(BH_PASS_COUNT, q, 0u);
        bh_narrow(bh_ss, slo_none, slo, shi, top_count);
        bh_top_slot = shi;
    }
    return m;
}

#endif
