// bh_select_packed.glsl: k-nearest selection on packed uint keys, fully unrolled.
// Takes: keys (squared-distance bits & ~BH_SLOT_MASK) | candidate, where candidate
// = 10 * (position of the block in the query's taken list) + photon in block.
// Returns: the k smallest keys, ascending, in bh_pk.  Every array index is a
// constant after the preprocessor expands BH_CX8, so bh_pk lives in registers;
// a min/max pair per slot and no branches (DESIGN.md: 0.16 s per 512x512 frame
// against 4-8 s for local-array insertion).
// Defines: BH_K (<= 128), BH_SLOT_BITS.
#ifndef BH_SELECT_PACKED_GLSL
#define BH_SELECT_PACKED_GLSL

#if BH_K > 128
#error BH_K above 128 is not supported by the packed selection; use select=network or insertion
#endif
#define BH_SLOT_MASK ((1u << BH_SLOT_BITS) - 1u)
#define BH_PK_SIZE (((BH_K + 7) / 8) * 8)

uint bh_pk[BH_PK_SIZE];

#define BH_CX(i) { uint lo_ = min(bh_pk[i], c); c = max(bh_pk[i], c); bh_pk[i] = lo_; }
#define BH_CX8(i) BH_CX(i) BH_CX(i + 1) BH_CX(i + 2) BH_CX(i + 3) \
                  BH_CX(i + 4) BH_CX(i + 5) BH_CX(i + 6) BH_CX(i + 7)

void bh_packed_init() {
    for (int i = 0; i < BH_PK_SIZE; ++i) {
        bh_pk[i] = 0xFFFFFFFFu;
    }
}

void bh_packed_offer(uint c) {
    BH_CX8(0)
#if BH_K > 8
    BH_CX8(8)
#endif
#if BH_K > 16
    BH_CX8(16)
#endif
#if BH_K > 24
    BH_CX8(24)
#endif
#if BH_K > 32
    BH_CX8(32)
#endif
#if BH_K > 40
    BH_CX8(40)
#endif
#if BH_K > 48
    BH_CX8(48)
#endif
#if BH_K > 56
    BH_CX8(56)
#endif
#if BH_K > 64
    BH_CX8(64)
#endif
#if BH_K > 72
    BH_CX8(72)
#endif
#if BH_K > 80
    BH_CX8(80)
#endif
#if BH_K > 88
    BH_CX8(88)
#endif
#if BH_K > 96
    BH_CX8(96)
#endif
#if BH_K > 104
    BH_CX8(104)
#endif
#if BH_K > 112
    BH_CX8(112)
#endif
#if BH_K > 120
    BH_CX8(120)
#endif
}

#endif
