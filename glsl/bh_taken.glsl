// bh_taken.glsl: the blocks a query has taken, held in registers (duplicate removal,
// paper section 7 step 4; the BH_DEDUP == BH_DEDUP_SET variant).
// Takes: block references in the order the query takes them.  Returns: whether a
// block was taken before (bh_taken_has), and the i-th block taken (bh_taken_get).
// Every access to bh_ts is a compile-time index in an unrolled group (BH_TS_GROUPS):
// a membership test is BH_TS_SIZE compares, an insertion BH_TS_SIZE selects, and no
// array is ever indexed by a variable, so nothing lives in local (scratch) memory,
// where a loop over a variable-indexed taken[] list costs O(n^2) slow reads per query.
// Defines: BH_TAKEN_MAX, a bound on the blocks one query takes (blockhash/gl/lookup.py
// taken_bound: min(L * B, blocks that can be taken before the candidate cap stops)).
#ifndef BH_TAKEN_GLSL
#define BH_TAKEN_GLSL

#define BH_TS_SIZE (((BH_TAKEN_MAX + 7) / 8) * 8)
#define BH_TS_NONE 0xFFFFFFFFu

#if BH_TS_SIZE == 8
#define BH_TS_GROUPS(M) M(0)
#elif BH_TS_SIZE == 16
#define BH_TS_GROUPS(M) M(0) M(8)
#elif BH_TS_SIZE == 24
#define BH_TS_GROUPS(M) M(0) M(8) M(16)
#elif BH_TS_SIZE == 32
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24)
#elif BH_TS_SIZE == 40
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32)
#elif BH_TS_SIZE == 48
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40)
#elif BH_TS_SIZE == 56
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48)
#elif BH_TS_SIZE == 64
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56)
#elif BH_TS_SIZE == 72
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64)
#elif BH_TS_SIZE == 80
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72)
#elif BH_TS_SIZE == 88
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80)
#elif BH_TS_SIZE == 96
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88)
#elif BH_TS_SIZE == 104
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88) M(96)
#elif BH_TS_SIZE == 112
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88) M(96) M(104)
#elif BH_TS_SIZE == 120
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88) M(96) M(104) M(112)
#elif BH_TS_SIZE == 128
#define BH_TS_GROUPS(M) M(0) M(8) M(16) M(24) M(32) M(40) M(48) M(56) M(64) M(72) M(80) M(88) M(96) M(104) M(112) M(120)
#else
#error BH_TAKEN_MAX above 128 is not supported by dedup=set; use dedup=branch or a smaller A * k
#endif

uint bh_ts[BH_TS_SIZE];

#define BH_TS_8(M, i) M(i) M(i + 1) M(i + 2) M(i + 3) M(i + 4) M(i + 5) M(i + 6) M(i + 7)

#define BH_TS_INIT1(i) bh_ts[i] = BH_TS_NONE;
#define BH_TS_INIT8(i) BH_TS_8(BH_TS_INIT1, i)
void bh_taken_init() {
    BH_TS_GROUPS(BH_TS_INIT8)
}

// Unused slots hold BH_TS_NONE, which is no block (block numbers are < 2^28).
#define BH_TS_HAS1(i) hit |= uint(bh_ts[i] == b);
#define BH_TS_HAS8(i) BH_TS_8(BH_TS_HAS1, i)
bool bh_taken_has(uint b) {
    uint hit = 0u;
    BH_TS_GROUPS(BH_TS_HAS8)
    return hit != 0u;
}

#define BH_TS_PUT1(i) bh_ts[i] = (uint(i) == n) ? b : bh_ts[i];
#define BH_TS_PUT8(i) BH_TS_8(BH_TS_PUT1, i)
// Records b as the n-th block taken (n < BH_TAKEN_MAX).
void bh_taken_put(uint n, uint b) {
    BH_TS_GROUPS(BH_TS_PUT8)
}

#define BH_TS_GET1(i) b = (uint(i) == n) ? bh_ts[i] : b;
#define BH_TS_GET8(i) BH_TS_8(BH_TS_GET1, i)
uint bh_taken_get(uint n) {
    uint b = BH_TS_NONE;
    BH_TS_GROUPS(BH_TS_GET8)
    return b;
}

#endif
