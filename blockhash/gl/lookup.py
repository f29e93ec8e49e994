"""Block Hashing queries in a GLSL fragment shader (paper section 7).

``GLLookup(index).query(points)`` answers like the CPU reference
(:meth:`BlockHashIndex.query`), with identical neighbour sets for the same
index: both hash in integers, compute float32 distances with the same
operations (``precise`` in GLSL), and order equal distances by photon slot.
One fragment per query writes its k (distance bits, slot) pairs to a shader
storage buffer; queries are processed in passes that fit the buffer limit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from blockhash.errors import CapacityError, InputError
from blockhash.gl.context import (
    bind_textures,
    check_gl,
    draw_fullscreen,
    get_context,
    home_framebuffer,
    time_draws,
)
from blockhash.gl.limits import MAX_TAKEN_SET, check_lookup
from blockhash.gl.packing import pack_index, set_photon_box
from blockhash.gl.shaderlib import NAMED, Variant, compile_program
from blockhash.index.block_hash_index import resolve_lookup
from blockhash.index.lookups.cells_query import GROUP_CELLS
from blockhash.index.lookups.walk import MAX_LEAVES, MAX_POPS, QUEUE_CAPACITY, walk_taken_bound
from blockhash.index.records.blocks import PHOTONS_PER_BLOCK
from blockhash.index.tables.params import candidate_cap
from blockhash.index.tables.thresholds import MAX_DEPTH, PROBE_CUTS, ThresholdLayout
from blockhash.validate import as_int, as_points

#: Queries per pass are capped so one draw stays short (llvmpipe runs a draw to completion).
MAX_QUERIES_PER_PASS = 1 << 18
#: Viewport width of a pass (queries wrap row by row).
QUERY_WIDTH = 1024
NO_SLOT = 0xFFFFFFFF


def slot_bits(L: int, B: int) -> int:
    """Bits that number a hash query's candidates (10 per taken block, at most L * B blocks)."""
    return max(1, int(L * B * 10 - 1).bit_length())


def taken_bound(L: int, B: int, cap: int) -> int:
    """Most blocks one hash query can take: at most L * B references, and (blocks being full
    but the last, and the cap checked before each block) at most ceil(cap / 10) + 1."""
    return min(L * B, (cap + 9) // PHOTONS_PER_BLOCK + 1)


def lookup_taken_bound(params, cap: int) -> int:
    """Most blocks one query of this index takes: :func:`taken_bound` for hashing; for the
    nearest-box-first walk (``params.best_first``), which has no L * B block cap,
    :func:`blockhash.index.lookups.walk.walk_taken_bound` (``ceil(cap / 10) + 1`` with
    compact blocks: at most ``cap + 9`` photons examined)."""
    if getattr(params, "best_first", False):
        return walk_taken_bound(params.B, cap)
    return taken_bound(params.L, params.B, cap)


def lookup_slot_bits(params, cap: int) -> int:
    """Bits that number the candidates of one query of this index (10 per taken block, at
    most :func:`lookup_taken_bound` blocks): the ``slot_bits`` that makes the CPU reference
    reproduce the shader's packed selections.  Hashing: :func:`slot_bits` (L, B)."""
    if getattr(params, "best_first", False):
        return max(1, int(lookup_taken_bound(params, cap) * PHOTONS_PER_BLOCK - 1).bit_length())
    return slot_bits(params.L, params.B)


def query_slot_bits(params, k: int, A: int, lookup: str | None = None) -> int:
    """:func:`lookup_slot_bits` of a query for k neighbours at A (the cap of
    :func:`..index.params.candidate_cap` for this index's ``lookup``)."""
    return lookup_slot_bits(params, candidate_cap(params, k, A, resolve_lookup(params, lookup)))


class GLLookup:
    """A BlockHashIndex uploaded to a GL context.

    Parameters
    ----------
    index : BlockHashIndex
    backend : {'auto', 'egl', 'osmesa'}, optional
    """

    def __init__(self, index, *, backend: str | None = None):
        starts = index.starts
        expected = np.minimum(np.arange(len(starts)) * PHOTONS_PER_BLOCK, len(index))
        if not np.array_equal(starts, expected):
            raise InputError("the GL lookup needs compact blocks (every block full but the last); "
                             "build the index with builder='bulk' or 'btree' (both compact)")
        self.index = index
        self.ctx = get_context(backend)
        with self.ctx:
            self.packed = pack_index(self.ctx, index)
            self._home = home_framebuffer(self.ctx)
        self._programs: dict = {}

    def defines(self, variant: Variant, k: int, cap: int, *, fetch_only: bool = False,
                lookup: str | None = None) -> dict:
        """The #defines of bh_lookup.glsl (bh_cells.glsl for the cell lookup) for this index,
        variant, k, candidate cap and lookup (default: the index params')."""
        prm = self.index.params
        lookup = resolve_lookup(prm, lookup)
        if lookup == "cells":
            if not self.packed.with_cells:
                raise InputError("lookup='cells' needs the cells uploaded: build GLLookup from an "
                                 "index whose params have cells=True (dataclasses.replace("
                                 "index.params, cells=True))")
            cells = self.index.cells
            return {"BH_CELLS": 1, "BH_K": k, "BH_CAP": cap, "BH_FETCH_ONLY": int(fetch_only),
                    "BH_CELL_MASK": cells.buckets - 1,  # one slot per bucket (cells.SLOTS)
                    "BH_CELL_FIRST": cells.first_level(cap), **self.packed.widths}
        prm = replace(prm, best_first=lookup == "walk")
        if prm.best_first:
            if getattr(self.index, "node_boxes", None) is None:
                raise InputError(f"{prm!r} walks node boxes, but the index has none; build it "
                                 "with the default preset (layout='adaptive')")
            if QUEUE_CAPACITY < 32 or QUEUE_CAPACITY % 32:
                raise InputError(
                    f"the walk's queue capacity QUEUE_CAPACITY={QUEUE_CAPACITY} must be a positive "
                    "multiple of 32 (glsl/bh_walk.glsl scans it in unrolled chunks of 32); "
                    "round it up to one")
        taken = lookup_taken_bound(prm, cap)
        if variant == NAMED["default"] and taken > MAX_TAKEN_SET:
            # The default keeps taken blocks in registers up to MAX_TAKEN_SET; a larger A * k
            # takes them in a list (dedup=branch): the same neighbours, more time per block.
            variant = replace(variant, dedup="branch")
        if variant.dedup == "set" and taken > MAX_TAKEN_SET:
            raise InputError(
                f"A * k = {cap:,} candidates can take up to {taken:,} blocks, more than the "
                f"{MAX_TAKEN_SET} that dedup=set holds in registers; use a smaller A or k, or a "
                "variant with dedup=branch (e.g. 'binary-branch-on-packed-box')")
        return {
            **variant.defines(),
            "BH_L": prm.L, "BH_B": prm.B, "BH_PX": prm.P[0], "BH_PY": prm.P[1], "BH_PZ": prm.P[2],
            "BH_T": self.index.thresholds.shape[1],
            "BH_ADAPTIVE": int(prm.layout == ThresholdLayout.ADAPTIVE), "BH_MAX_DEPTH": MAX_DEPTH,
            "BH_PROBE": int(prm.probe), "BH_PROBE_CUTS": PROBE_CUTS,
            "BH_BUCKETS": prm.buckets, "BH_K": k, "BH_CAP": cap, **self.packed.widths,
            "BH_SLOT_BITS": lookup_slot_bits(prm, cap), "BH_FETCH_ONLY": int(fetch_only),
            "BH_TAKEN_MAX": taken,
            # Blocks bh_take stops at: hashing L * B; the walk none (its bound, never reached).
            "BH_TAKE_LIMIT": taken if prm.best_first else prm.L * prm.B,
            "BH_BEST_FIRST": int(prm.best_first), "BH_WALK_TREES": prm.walk_tables(k), "BH_CELLS": 0,
            "BH_QUEUE": QUEUE_CAPACITY,
            "BH_MAX_POPS": MAX_POPS, "BH_MAX_LEAVES": MAX_LEAVES,
            "BH_NODES": max(1, self.index.thresholds.shape[1] // 2),
        }

    def textures(self) -> dict:
        """Sampler name -> texture of the uploaded index."""
        p = self.packed
        return {"bh_blocks": p.blocks, "bh_headers": p.headers, "bh_refs": p.refs,
                "bh_thresholds": p.thresholds, "bh_boxes": p.boxes, "bh_cells": p.cells,
                "bh_points": p.points}

    def set_uniforms(self, program) -> None:
        """The photon box (bh_box.glsl) and power scale, as exact float32 values."""
        set_photon_box(program, self.index.quantizer, self.index.records.power_scale)
        if "bh_group_cells" in program:
            program["bh_group_cells"].value = GROUP_CELLS

    def _program(self, variant: Variant, k: int, cap: int, fetch_only: bool = False,
                 lookup: str | None = None):
        """The lookup program; the query count and viewport width are uniforms, so one
        program serves every image size."""
        defines = self.defines(variant, k, cap, fetch_only=fetch_only, lookup=lookup)
        key = tuple(defines.items())
        if key not in self._programs:
            self._programs[key] = compile_program(self.ctx, "bh_query.frag", defines)
        return self._programs[key]

    def query(self, points, k=None, *, A=None, variant="default", fetch_only: bool = False,
              width: int | None = None, lookup: str | None = None):
        """Approximate k nearest photons computed by the shader; see BlockHashIndex.query.

        Returns ``(distances, indices)`` of shape (m, k) (no squeezing); rows with NaN
        or inf get distance inf and index N.  ``self.counters`` holds the candidates
        examined per query and ``gl.draw_seconds``, the time of the draws alone
        (no compile, upload or read-back), and ``query.blocks_culled.mean``, the blocks
        skipped by culling (variants with cull 'box').  ``fetch_only`` runs the memory-floor
        shader for benchmarks: same candidates, no selection, no neighbours returned (the
        default preset's nearest-box-first walk then prunes nothing, so it examines the
        candidates of a walk that never holds k neighbours).
        ``width`` is the queries per viewport row (default 1024): an image's width makes
        the fragments that run side by side neighbouring pixels (same results).
        """
        index = self.index
        n = len(index)
        k = index.params.k if k is None else as_int(k, "k", minimum=1, maximum=n,
                                                     hint=f"use k <= N={n:,}")
        A = index.params.A if A is None else as_int(A, "A", minimum=1)
        v = variant if isinstance(variant, Variant) else Variant.parse(variant)
        check_lookup(self.ctx, index.params, v, k, A, lookup)  # k, loop limits, before compiling
        q = as_points(points, "points", dtype=np.float32, finite=False)
        m = len(q)
        pairs = np.empty((m, k, 2), dtype=np.uint32)
        counts = np.empty(m, dtype=np.uint32)
        culled = np.empty(m, dtype=np.uint32)
        per_pass = self._per_pass(k)
        self._draw_seconds = 0.0
        with self.ctx:
            for first in range(0, m, per_pass):
                chunk = q[first:first + per_pass]
                self._run(chunk, v, k, self.cap(k, A, lookup), pairs[first:first + len(chunk)],
                          counts[first:first + len(chunk)], culled[first:first + len(chunk)],
                          fetch_only, width, lookup)
        if resolve_lookup(index.params, lookup) == "cells":
            # The cell lookup writes its k in the order it meets them: nearest first here,
            # ties by slot (empty entries sort last: inf bits, slot 0xFFFFFFFF).
            key = (pairs[..., 0].astype(np.uint64) << np.uint64(32)) | pairs[..., 1]
            pairs = np.take_along_axis(pairs, np.argsort(key, axis=1)[..., None], axis=1)
        slots = pairs[..., 1].astype(np.int64)
        d2 = pairs[..., 0].copy().view(np.float32)
        found = (slots != NO_SLOT) & np.isfinite(d2)  # overflowed distances: missing, as on the CPU
        distances = np.where(found, np.sqrt(d2.astype(np.float64)), np.inf)
        indices = np.where(found, index.order[np.where(found, slots, 0)], n)
        finite = np.isfinite(q).all(axis=1)
        self.counters = {"query.points": float(m), "gl.draw_seconds": self._draw_seconds,
                         "query.candidates.mean": float(counts[finite].mean()) if finite.any() else 0.0,
                         "query.blocks_culled.mean": float(culled[finite].mean()) if finite.any() else 0.0}
        return distances, indices

    def _run(self, q, variant, k, cap, pairs_out, counts_out, culled_out, fetch_only=False,
             width=None, lookup=None):
        with _Pass(self, q, variant, k, cap, fetch_only, width, lookup) as p:
            self._draw_seconds += draw_fullscreen(self.ctx, p.prog, p.fbo, p.size)
            check_gl(self.ctx, "the lookup draw")
            pairs_out[:] = np.frombuffer(p.results.read(), dtype=np.uint32).reshape(len(q), k, 2)
            counts_out[:] = np.frombuffer(p.counts.read(), dtype=np.uint32)
            culled_out[:] = np.frombuffer(p.culled.read(), dtype=np.uint32)

    def time_draws(self, points, k=None, *, A=None, variant="default", fetch_only: bool = False,
                   repeat: int = 10, warmup: int = 2, width: int | None = None,
                   lookup: str | None = None) -> dict:
        """Time the lookup's draws the way GPU work is timed; returns the per-draw times.

        The queries are uploaded once; per pass, ``warmup`` draws of the very program
        that is then timed, and ``repeat`` back-to-back timed draws with no read-back
        between them (:func:`blockhash.gl.context.time_draws`); ``width`` as in
        :meth:`query`.  Returns
        ``{'wall': [...], 'gpu': [...]}``, seconds per draw summed over the passes.
        """
        n = len(self.index)
        k = self.index.params.k if k is None else as_int(k, "k", minimum=1, maximum=n)
        A = self.index.params.A if A is None else as_int(A, "A", minimum=1)
        repeat = as_int(repeat, "repeat", minimum=1)
        v = variant if isinstance(variant, Variant) else Variant.parse(variant)
        q = as_points(points, "points", dtype=np.float32, finite=False)
        wall = np.zeros(repeat)
        gpu = np.zeros(repeat)
        with self.ctx:
            for first in range(0, len(q), self._per_pass(k)):
                chunk = q[first:first + self._per_pass(k)]
                with _Pass(self, chunk, v, k, self.cap(k, A, lookup), fetch_only, width,
                           lookup) as p:
                    w, g = time_draws(self.ctx, p.prog, p.fbo, p.size, repeat=repeat, warmup=warmup)
                    check_gl(self.ctx, "the timed lookup draws")
                wall += w
                gpu += g
        return {"wall": wall.tolist(), "gpu": gpu.tolist()}

    def cap(self, k: int, A: int, lookup: str | None = None) -> int:
        """The candidate cap of this index's ``lookup`` (:func:`..index.params.candidate_cap`)."""
        return candidate_cap(self.index.params, k, A, resolve_lookup(self.index.params, lookup))

    def _per_pass(self, k: int) -> int:
        limit = self.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27) // (8 * k)
        return max(1, min(MAX_QUERIES_PER_PASS, limit))

    def release(self):
        with self.ctx:
            self._home.use()
            self.packed.release()
        self._programs.clear()  # the programs stay in shaderlib's cache


class _Pass:
    """The GL objects of one pass of queries: query texture, result buffers, framebuffer,
    and the program with its uniforms and textures bound; released on exit."""

    def __init__(self, lookup: GLLookup, q, variant, k, cap, fetch_only, width=None, which=None):
        ctx = lookup.ctx
        self.lookup = lookup
        m = len(q)
        limit = ctx.info.get("GL_MAX_TEXTURE_SIZE", 16384)
        width = QUERY_WIDTH if width is None else as_int(
            width, "width", minimum=1, maximum=limit, hint="queries per row of the query texture")
        width = min(m, width)
        height = -(-m // width)
        if height > limit:
            raise CapacityError(f"{m:,} queries at width={width:,} need {height:,} rows > "
                                f"GL_MAX_TEXTURE_SIZE={limit:,}; use a larger width")
        self.size = (width, height)
        grid = np.zeros((height * width, 4), dtype=np.float32)
        grid[:m, :3] = q
        self.qtex = ctx.texture((width, height), 4, grid.tobytes(), dtype="f4")
        self.qtex.filter = (ctx.NEAREST, ctx.NEAREST)
        self.results = ctx.buffer(reserve=m * k * 8)
        self.counts = ctx.buffer(reserve=m * 4)
        self.culled = ctx.buffer(reserve=m * 4)
        self.color = ctx.renderbuffer((width, height), 4, dtype="f1")
        self.fbo = ctx.framebuffer(color_attachments=[self.color])
        ready = False
        try:
            check_gl(ctx, f"allocating buffers for {m:,} queries x k={k}")
            self.prog = lookup._program(variant, k, cap, fetch_only, which)
            lookup.set_uniforms(self.prog)
            self.prog["bh_query_w"].value = width
            self.prog["bh_queries_n"].value = m
            bind_textures(self.prog, {**lookup.textures(), "bh_queries": self.qtex})
            self.results.bind_to_storage_buffer(0)
            self.counts.bind_to_storage_buffer(1)
            self.culled.bind_to_storage_buffer(2)
            ready = True
        finally:
            if not ready:
                self.__exit__()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        # moderngl rebinds its current framebuffer after creating one: never leave a
        # framebuffer that is about to be released current.
        self.lookup._home.use()
        for obj in (self.qtex, self.results, self.counts, self.culled, self.fbo, self.color):
            obj.release()
        return False
