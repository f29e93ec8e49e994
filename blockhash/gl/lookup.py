"""Block Hashing queries in a GLSL fragment shader (paper section 7).

``GLLookup(index).query(points)`` answers like the CPU reference
(:meth:`BlockHashIndex.query`), with identical neighbour sets for the same
index: both hash in integers, compute float32 distances with the same
operations (``precise`` in GLSL), and order equal distances by photon slot.
One fragment per query writes its k (distance bits, slot) pairs to a shader
storage buffer; queries are processed in passes that fit the buffer limit.
"""

from __future__ import annotations


import numpy as np

from ..errors import InputError
from ..index.thresholds import MAX_DEPTH, ThresholdLayout
from ..validate import as_int, as_points
from .context import bind_textures, check_gl, draw_fullscreen, get_context, home_framebuffer
from ..index.blocks import PHOTONS_PER_BLOCK
from .limits import check_lookup
from .packing import pack_index
from .shaderlib import Variant, compile_program

#: Queries per pass are capped so one draw stays short (llvmpipe runs a draw to completion).
MAX_QUERIES_PER_PASS = 1 << 18
NO_SLOT = 0xFFFFFFFF


def slot_bits(L: int, B: int) -> int:
    """Bits that number a query's candidates (10 per taken block, at most L * B blocks)."""
    return max(1, int(L * B * 10 - 1).bit_length())


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

    def defines(self, variant: Variant, k: int, cap: int, *, fetch_only: bool = False) -> dict:
        """The #defines of bh_lookup.glsl for this index, variant, k and candidate cap."""
        prm = self.index.params
        return {
            **variant.defines(),
            "BH_L": prm.L, "BH_B": prm.B, "BH_PX": prm.P[0], "BH_PY": prm.P[1], "BH_PZ": prm.P[2],
            "BH_NESTED": int(prm.layout == ThresholdLayout.NESTED), "BH_T": self.index.thresholds.shape[1],
            "BH_ADAPTIVE": int(prm.layout == ThresholdLayout.ADAPTIVE), "BH_MAX_DEPTH": MAX_DEPTH,
            "BH_BUCKETS": prm.buckets, "BH_K": k, "BH_CAP": cap, **self.packed.widths,
            "BH_SLOT_BITS": slot_bits(prm.L, prm.B), "BH_FETCH_ONLY": int(fetch_only),
        }

    def textures(self) -> dict:
        """Sampler name -> texture of the uploaded index."""
        p = self.packed
        return {"bh_blocks": p.blocks, "bh_headers": p.headers, "bh_refs": p.refs,
                "bh_thresholds": p.thresholds}

    def set_uniforms(self, program) -> None:
        """The photon box (bh_box.glsl) and power scale, as exact float32 values."""
        box = self.index.quantizer
        program["bh_lo"].value = tuple(float(x) for x in box.lo)
        program["bh_step"].value = tuple(float(x) for x in box.step)
        program["bh_inv_step"].value = tuple(float(x) for x in box.inv_step)
        if "bh_power_scale" in program:
            program["bh_power_scale"].value = float(self.index.records.power_scale)

    def _program(self, variant: Variant, k: int, cap: int, width: int, count: int,
                 fetch_only: bool = False):
        defines = {**self.defines(variant, k, cap, fetch_only=fetch_only),
                   "BH_QUERY_W": width, "BH_QUERIES": count}
        key = tuple(defines.items())
        if key not in self._programs:
            self._programs[key] = compile_program(self.ctx, "bh_query.frag", defines)
        return self._programs[key]

    def query(self, points, k=None, *, A=None, variant="default", fetch_only: bool = False):
        """Approximate k nearest photons computed by the shader; see BlockHashIndex.query.

        Returns ``(distances, indices)`` of shape (m, k) (no squeezing); rows with NaN
        or inf get distance inf and index N.  ``self.counters`` holds the candidates
        examined per query and ``gl.draw_seconds``, the time of the draws alone
        (no compile, upload or read-back).  ``fetch_only`` runs the memory-floor
        shader for benchmarks: same candidates, no selection, no neighbours returned.
        """
        index = self.index
        n = len(index)
        k = index.params.k if k is None else as_int(k, "k", minimum=1, maximum=n,
                                                     hint=f"use k <= N={n:,}")
        A = index.params.A if A is None else as_int(A, "A", minimum=1)
        v = variant if isinstance(variant, Variant) else Variant.parse(variant)
        check_lookup(self.ctx, index.params, v, k, A)  # k and loop limits, before any compile
        q = as_points(points, "points", dtype=np.float32, finite=False)
        m = len(q)
        pairs = np.empty((m, k, 2), dtype=np.uint32)
        counts = np.empty(m, dtype=np.uint32)
        limit = self.ctx.info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27) // (8 * k)
        per_pass = max(1, min(MAX_QUERIES_PER_PASS, limit))
        self._draw_seconds = 0.0
        with self.ctx:
            for first in range(0, m, per_pass):
                chunk = q[first:first + per_pass]
                self._run(chunk, v, k, A * k, pairs[first:first + len(chunk)],
                          counts[first:first + len(chunk)], fetch_only)
        slots = pairs[..., 1].astype(np.int64)
        d2 = pairs[..., 0].copy().view(np.float32)
        found = (slots != NO_SLOT) & np.isfinite(d2)  # overflowed distances: missing, as on the CPU
        distances = np.where(found, np.sqrt(d2.astype(np.float64)), np.inf)
        indices = np.where(found, index.order[np.where(found, slots, 0)], n)
        finite = np.isfinite(q).all(axis=1)
        self.counters = {"query.points": float(m), "gl.draw_seconds": self._draw_seconds,
                         "query.candidates.mean": float(counts[finite].mean()) if finite.any() else 0.0}
        return distances, indices

    def _run(self, q, variant, k, cap, pairs_out, counts_out, fetch_only=False):
        ctx = self.ctx
        m = len(q)
        width = min(m, 1024)
        height = -(-m // width)
        grid = np.zeros((height * width, 4), dtype=np.float32)
        grid[:m, :3] = q
        qtex = ctx.texture((width, height), 4, grid.tobytes(), dtype="f4")
        qtex.filter = (ctx.NEAREST, ctx.NEAREST)
        results = ctx.buffer(reserve=m * k * 8)
        counts = ctx.buffer(reserve=m * 4)
        color = ctx.renderbuffer((width, height), 4, dtype="f1")
        fbo = ctx.framebuffer(color_attachments=[color])
        check_gl(ctx, f"allocating buffers for {m:,} queries x k={k}")
        try:
            prog = self._program(variant, k, cap, width, m, fetch_only)
            self.set_uniforms(prog)
            bind_textures(prog, {**self.textures(), "bh_queries": qtex})
            results.bind_to_storage_buffer(0)
            counts.bind_to_storage_buffer(1)
            self._draw_seconds += draw_fullscreen(ctx, prog, fbo, (width, height))
            check_gl(ctx, "the lookup draw")
            pairs_out[:] = np.frombuffer(results.read(), dtype=np.uint32).reshape(m, k, 2)
            counts_out[:] = np.frombuffer(counts.read(), dtype=np.uint32)
        finally:
            # moderngl rebinds its current framebuffer after creating one: never leave a
            # framebuffer that is about to be released current.
            self._home.use()
            for obj in (qtex, results, counts, fbo, color):
                obj.release()

    def release(self):
        with self.ctx:
            self._home.use()
            self.packed.release()
        self._programs.clear()  # the programs stay in shaderlib's cache
