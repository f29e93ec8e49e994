// bh_select_packed.glsl: k-nearest selection on packed uint keys, fully unrolled.
// Takes: keys (squared-distance bits & ~BH_SLOT_MASK) | candidate, where candidate
// = 10 * (position of the block in the query's taken list) + photon in block.
// Returns: the k smallest keys, ascending, in bh_pk (BH_PK_SIZE >= k slots; the
// extra slots hold larger keys and are never read).  Every access to bh_pk goes
// through BH_PK_GROUPS, so all indices are constants and the array lives in
// registers: a min/max pair per slot and no branches.  A rolled loop or a
// variable index would put the array in scratch memory, several times slower
// under llvmpipe (0.16 s against 4-8 s per 512x512 frame).
// Defines: BH_K (<= 128), BH_SLOT_BITS.
#ifndef BH_SELECT_PACKED_GLSL
#define BH_SELECT_PACKED_GLSL

#if BH_K > 128
#error BH_K above 128 is not supported by the packed selection; use select=network or insertion
#endif
#define BH_SLOT_MASK ((1u << BH_SLOT_BITS) - 1u)
#define BH_PK_SIZE (((BH_K + 7) / 8) * 8)
#define BH_PK_EMPTY 0xFFFFFFFFu

uint bh_pk[BH_PK_SIZE];

// BH_PK_GROUPS(M) expands to M(0) M(8) ... over the groups of 8 slots.
#if BH_PK_SIZE == 8
#define BH_PK_GROUPS(M) M(0)
#elif BH_PK_SIZE == 16
#define BH_PK_GROUPS(M) M(0) M(8)
#elif BH_PK_SIZE == 24
#define BH_PK_GROUPS(M) M(0) M(8) M(16)
#elif BH_PK_SIZE == 32
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24)
#elif BH_PK_SIZE == 40
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32)
#elif BH_PK_SIZE == 48
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40)
#elif BH_PK_SIZE == 56
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48)
#elif BH_PK_SIZE == 64
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56)
#elif BH_PK_SIZE == 72
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64)
#elif BH_PK_SIZE == 80
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72)
#elif BH_PK_SIZE == 88
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80)
#elif BH_PK_SIZE == 96
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88)
#elif BH_PK_SIZE == 104
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88) M(96)
#elif BH_PK_SIZE == 112
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88) M(96) M(104)
#elif BH_PK_SIZE == 120
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88) M(96) M(104) M(112)
#elif BH_PK_SIZE == 128
#define BH_PK_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88) M(96) M(104) M(112) M(120)
#else
#error BH_PK_SIZE out of range
#endif

#define BH_PK_INIT1(i) bh_pk[i] = BH_PK_EMPTY;
#define BH_PK_INIT8(i) BH_PK_INIT1(i) BH_PK_INIT1(i + 1) BH_PK_INIT1(i + 2) BH_PK_INIT1(i + 3) \
                       BH_PK_INIT1(i + 4) BH_PK_INIT1(i + 5) BH_PK_INIT1(i + 6) BH_PK_INIT1(i + 7)
#define BH_CX(i) { uint lo_ = min(bh_pk[i], c); c = max(bh_pk[i], c); bh_pk[i] = lo_; }
#define BH_CX8(i) BH_CX(i) BH_CX(i + 1) BH_CX(i + 2) BH_CX(i + 3) \
                  BH_CX(i + 4) BH_CX(i + 5) BH_CX(i + 6) BH_CX(i + 7)

void bh_packed_init() {
    BH_PK_GROUPS(BH_PK_INIT8)
}

void bh_packed_offer(uint c) {
    BH_PK_GROUPS(BH_CX8)
}

#endif
