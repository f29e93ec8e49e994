"""Limits of the Block Hashing lookup shader, checked before anything is compiled.

Two limits bound what ``GLLookup.query`` and the caustic pass accept:

``MAX_K`` (128)
    The packed selection (glsl/bh_select_packed.glsl, the default variant) keeps
    the k best keys in registers through a table of unrolled compare-exchange
    groups (``BH_PK_GROUPS``) written out up to 128 slots; above it the shader
    stops at ``#error``.  The other selections keep ``uvec2 bh_best[k]`` in a
    local array whose compile time grows fast with its size on llvmpipe, and the
    caustic pass reads ``bh_best`` too, so one limit holds for every variant.
    The CPU reference (:meth:`BlockHashIndex.query`) has no such limit.

``LOOP_LIMIT`` (llvmpipe only)
    Mesa's llvmpipe silently ends every loop of a shader invocation once 65,535
    iterations have run in total across its loops (loops of at most 32 constant
    iterations are unrolled and do not count).  A lookup that ran into it would
    return fewer candidates than the CPU reference, without an error.
    :func:`loop_iterations` bounds the iterations of one lookup from above
    (the loops of glsl/bh_lookup.glsl, bh_walk.glsl, bh_hash.glsl, bh_buckets.glsl,
    bh_select.glsl and bh_query.frag); a lookup whose bound exceeds the limit is
    refused on llvmpipe.  With the default preset's index built for the A it is
    queried at, k = 8 passes up to A = 256, k = 50 up to A = 64 and k = 100 up
    to A = 32 (the nearest-box-first walk's ``MAX_POPS`` queue scans and its
    ``MAX_LEAVES`` buckets of B references, each scanned against the taken list
    of dedup=branch, which the default uses beyond 128 taken blocks, dominate; with
    no L * B block cap the walk's list holds up to ceil(A k / 10) + 1 blocks); the
    largest allowed A is tested to equal the CPU reference
    (tests/gl/test_extremes_gl.py).  Other drivers (an NVIDIA GPU through
    EGL) have no such limit.
"""

from __future__ import annotations

import math

from blockhash.errors import CapacityError, InputError
from blockhash.gl.shaderlib import NAMED
from blockhash.index.lookups.walk import MAX_LEAVES, MAX_POPS, QUEUE_CAPACITY, walk_taken_bound
from blockhash.index.tables.params import candidate_cap
from blockhash.index.tables.thresholds import MAX_DEPTH, PROBE_CUTS, ThresholdLayout

#: Largest k the lookup shader keeps (the packed selection's unrolled table ends at 128).
MAX_K = 128
#: llvmpipe's total loop iterations per shader invocation (Mesa gallivm).
LOOP_LIMIT = 65535
#: Bits of a binary threshold search per axis: thresholds per row are below 2**13.
_SEARCH_STEPS = 13
#: Taken blocks held in registers by dedup=set (glsl/bh_taken.glsl; GLLookup's MAX_TAKEN_SET).
MAX_TAKEN_SET = 128
#: Unrolled compares per chunk of the taken-list scan (glsl/bh_lookup.glsl BH_SCAN).
SCAN_CHUNK = 32


def is_llvmpipe(ctx) -> bool:
    """True when ``ctx`` renders with Mesa's llvmpipe (which has the loop limit)."""
    return "llvmpipe" in str(ctx.info.get("GL_RENDERER", "")).lower()


def loop_iterations(params, variant, k: int, cap: int) -> int:
    """An upper bound on the loop iterations one lookup runs in the shader.

    Hashing descends L trees (adaptive layout: at most ``MAX_DEPTH`` nodes each; grids:
    three binary searches) and, with probing, ``PROBE_CUTS`` more per table; the priority
    order adds ``L * L``.  The reference loop visits at most ``R`` references, ``L * B``
    from the query's own buckets and ``PROBE_CUTS * L * B`` from probed ones; with a taken
    list (dedup branch or zero) each scans the blocks taken so far (at most
    ``min(L B, ceil(cap / 10) + 1)``) in chunks of ``SCAN_CHUNK`` unrolled compares; the
    candidate loop runs at most ``cap + 10`` times; insertion selection adds up to k
    shifts per candidate; the output adds k.

    The nearest-box-first walk (``params.best_first``, glsl/bh_walk.glsl) replaces hashing:
    ``walk_trees`` root pushes, then at most ``MAX_POPS`` pops, each a scan of the queue and
    two pushes onto it (each scan at most ``QUEUE_CAPACITY / 32`` chunks), and at most
    ``MAX_LEAVES`` buckets of at most ``B`` references each; with no L * B block cap its
    taken list holds up to ``min(MAX_LEAVES B, ceil(cap / 10) + 1)`` blocks
    (:func:`blockhash.index.lookups.walk.walk_taken_bound`), a reference being scanned
    against one fewer at most (the cap ends the walk once that many are taken).
    """
    L, B = params.L, params.B
    probes = PROBE_CUTS if params.probe else 0
    refs = L * B * (1 + probes)
    taken = min(L * B, math.ceil(cap / 10) + 1)
    scanned = taken  # the taken blocks a reference is scanned against at most
    walk = params.best_first
    if walk:
        refs = MAX_LEAVES * B
        # A reference is scanned while ntaken < its bound (bh_take stops at the cap, which
        # ceil(cap / 10) full blocks reach): ceil(cap / 10) blocks at most.
        taken = walk_taken_bound(B, cap)
        scanned = taken - 1
    if params.layout == ThresholdLayout.ADAPTIVE:
        hash_steps = MAX_DEPTH * (1 + probes)  # the kd-tree descent: a constant loop, too long to unroll
    elif variant.search == "linear":
        hash_steps = int(sum(params.P))
    else:
        hash_steps = 3 * _SEARCH_STEPS
    dedup = variant.dedup
    set_fits = dedup == "set" and taken <= MAX_TAKEN_SET
    is_default = variant == NAMED["default"]
    scan = 0 if set_fits else math.ceil(scanned / SCAN_CHUNK)
    if dedup == "set" and not set_fits and not is_default:
        scan = 0  # refused before compiling anyway (GLLookup.defines)
    hashing = L * hash_steps + L * L
    if walk:
        chunks = QUEUE_CAPACITY // 32
        hashing = params.walk_tables(k) * (1 + chunks) + MAX_POPS * (1 + 3 * chunks)
    total = hashing + refs * (1 + scan) + cap + 10 + k
    if variant.select == "insertion":
        total += (cap + 10) * k
    return int(total)


def largest_A(params, variant, k: int) -> int:
    """The largest A whose lookup keeps within ``LOOP_LIMIT`` (0 if none does)."""
    lookup = "walk" if params.best_first else "hash"
    lo, hi = 0, 1
    while (loop_iterations(params, variant, k, candidate_cap(params, k, hi, lookup)) <= LOOP_LIMIT
           and hi < 1 << 20):
        lo, hi = hi, hi * 2
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if loop_iterations(params, variant, k, candidate_cap(params, k, mid, lookup)) <= LOOP_LIMIT:
            lo = mid
        else:
            hi = mid
    return lo


#: Passes of the cell lookup's counting selection at most (glsl/bh_cells.glsl): the first,
#: 12 on the distance bits (its splits applied, then 11), 11 on the slots, the pass that writes or sums the k, and one
#: that finds the k-th for the estimate.
CELL_PASSES = 1 + 12 + 11 + 1 + 1


def cell_loop_iterations(k: int, cap: int) -> int:
    """An upper bound on the loop iterations of one cell lookup in the shader: per pass, the
    27 cells (a loop with a uniform bound) and the candidates in chunks of 4 (at most
    ``cap / 4 + 27``); the own cells' and the groups' loops are unrolled; the output adds k."""
    return int(CELL_PASSES * (27 + math.ceil(cap / 4) + 27) + k)


def check_lookup(ctx, params, variant, k: int, A: int, lookup=None) -> None:
    """Raise before compiling when the shader cannot run this lookup exactly.

    InputError for k above :data:`MAX_K`; CapacityError on llvmpipe when the
    lookup could run into its loop limit and silently lose candidates.
    """
    if k > MAX_K:
        raise InputError(
            f"k={k:,} is above the lookup shader's limit MAX_K={MAX_K} (the selection keeps the "
            f"k best in unrolled registers, glsl/bh_select_packed.glsl); use k <= {MAX_K}, or "
            "the CPU query BlockHashIndex.query, or the kd-tree shader (GLKdTree, k <= 512)")
    from blockhash.index.block_hash_index import resolve_lookup

    if ctx is not None and is_llvmpipe(ctx) and resolve_lookup(params, lookup) == "cells":
        need = cell_loop_iterations(k, A * k)
        if need > LOOP_LIMIT:
            best = max(1, (4 * ((LOOP_LIMIT - k) // CELL_PASSES - 54)) // k)
            raise CapacityError(
                f"the cell lookup with k={k}, A={A} (A*k={A * k:,} candidates) may run up to "
                f"{need:,} shader loop iterations, above llvmpipe's {LOOP_LIMIT:,} (beyond it "
                f"llvmpipe silently stops the loops and neighbours go missing); use A <= {best}, "
                "or the CPU query BlockHashIndex.query, or a GPU driver")
        return
    if ctx is not None and is_llvmpipe(ctx):
        need = loop_iterations(params, variant, k, candidate_cap(params, k, A, resolve_lookup(
            params, lookup)))
        if need > LOOP_LIMIT:
            best = largest_A(params, variant, k)
            way = (f"use A <= {best}" if best >= 1 else "use a smaller k, L or B")
            raise CapacityError(
                f"the lookup with k={k}, A={A} (A*k={A * k:,} candidates), L={params.L}, "
                f"B={params.B}, variant {variant.name} may run up to "
                f"{need:,} shader loop iterations, above llvmpipe's {LOOP_LIMIT:,} (beyond it "
                f"llvmpipe silently stops the loops and neighbours go missing); {way}, or the "
                "CPU query BlockHashIndex.query, or a GPU driver")
