// bh_variants.glsl: the numbered ids of every shader variant choice.
// Takes: nothing.  Returns: the id constants that the selector defines
// (BH_THRESHOLD_SEARCH, BH_DEDUP, BH_PRIORITY, BH_SELECT, BH_CULL) are compared with.
// Python (blockhash/gl/shaderlib.py, class Variant) emits the selectors; the ids
// here and there must agree (tests/gl/test_shaderlib.py checks it).
#ifndef BH_VARIANTS_GLSL
#define BH_VARIANTS_GLSL

// Threshold search (paper section 7: "linear time ... or logarithmic time using binary search").
#define BH_SEARCH_LINEAR 0
#define BH_SEARCH_BINARY 1

// Duplicate block removal (section 7: branch, or "multiply redundant photons by zero"),
// both over a list of taken blocks in a local array; or skip, with the taken blocks in
// registers (bh_taken.glsl: no variable-indexed array).
#define BH_DEDUP_BRANCH 0
#define BH_DEDUP_ZERO 1
#define BH_DEDUP_SET 2

// Bucket order (section 4.4): by priority alpha, or plain table order.
#define BH_PRIORITY_OFF 0
#define BH_PRIORITY_ON 1

// k-nearest selection: sorted insertion (data-dependent loop), a branch-free
// compare-exchange network over (distance bits, slot) keys, or that network fully
// unrolled over single uint keys (distance bits with the low bits replaced by the
// candidate's position in the candidate list: exact up to 2^-(23-BH_SLOT_BITS)
// relative near-ties, which the CPU reference reproduces).
#define BH_SELECT_INSERTION 0
#define BH_SELECT_NETWORK 1
#define BH_SELECT_PACKED 2
// The same keys a block at a time: the block's keys sorted, then merged into the list
// by a bitonic merge (bh_select_merge.glsl); same result as packed.
#define BH_SELECT_MERGE 3

// Block culling: none, or skip a block whose box (words 61-63 of the GL upload) is
// farther than the current k-th neighbour (bh_lookup.glsl bh_block_far); same results.
// The walk (BH_BEST_FIRST) culls whatever BH_CULL, and does not examine culled blocks.
#define BH_CULL_OFF 0
#define BH_CULL_BOX 1

#endif
