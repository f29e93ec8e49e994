// bh_select.glsl: keep the k nearest candidates (paper 4.4: selection, not a priority queue).
// Takes: candidates as keys (float32 squared distance bits, photon slot); for
// non-negative floats the bits order like the values, so keys compare
// lexicographically exactly as the CPU reference orders (distance, slot).
// Returns: the k smallest keys, ascending, in bh_best.
// Defines: BH_SELECT (insertion | network), BH_K.
#ifndef BH_SELECT_GLSL
#define BH_SELECT_GLSL

#define BH_NO_KEY uvec2(0xFFFFFFFFu, 0xFFFFFFFFu)
// The network runs over groups of 8 slots, an inner loop the compiler unrolls:
// llvmpipe caps the iterations a shader's loops may run in total (about 65,536),
// and a rolled loop of k steps per candidate hits that cap at A*k*k ~ 30,000.
#define BH_GROUP 8
#define BH_K_PAD (((BH_K + BH_GROUP - 1) / BH_GROUP) * BH_GROUP)

uvec2 bh_best[BH_K_PAD];

void bh_select_init() {
    for (int i = 0; i < BH_K_PAD; ++i) {
        bh_best[i] = BH_NO_KEY;
    }
}

bool bh_key_less(uvec2 a, uvec2 b) {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
}

void bh_select_offer(uvec2 c) {
#if BH_SELECT == BH_SELECT_INSERTION
    if (!bh_key_less(c, bh_best[BH_K - 1])) {
        return;
    }
    int j = BH_K - 1;
    for (; j > 0; --j) {  // shift larger keys up until c's place is found
        uvec2 prev = bh_best[j - 1];
        if (!bh_key_less(c, prev)) {
            break;
        }
        bh_best[j] = prev;
    }
    bh_best[j] = c;
#elif BH_SELECT == BH_SELECT_NETWORK
    for (int g = 0; g < BH_K_PAD; g += BH_GROUP) {  // compare-exchange down the sorted list
        for (int u = 0; u < BH_GROUP; ++u) {            // no branches; padding slots hold
            int i = g + u;                              // larger keys and are never read
            bool lt = bh_key_less(c, bh_best[i]);
            uvec2 lo = lt ? c : bh_best[i];
            c = lt ? bh_best[i] : c;
            bh_best[i] = lo;
        }
    }
#elif BH_SELECT != BH_SELECT_PACKED && BH_SELECT != BH_SELECT_MERGE
#error unknown BH_SELECT
#endif
}

#endif
