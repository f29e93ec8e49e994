r"""The exact kNN baseline in the same medium: a balanced kd-tree searched in a fragment shader.

Paper section 2: "if the tree is balanced it can be stored as a heap in a
single array", and a query "may require an exhaustive search ... via recursive
descent. This requires a stack the same size as the depth of the tree."  This
module is that baseline, in GLSL beside the Block Hashing lookup, so that the
two are timed in the same medium and compared for accuracy.

Layout (Jensen's balanced photon map): a *left-balanced* tree, i.e. the
complete binary tree of N nodes stored as a heap -- node ``i`` has children
``2i + 1`` and ``2i + 2``, a child exists iff its number is below N, and N
photons take exactly N nodes (no padding, no empty markers).  Every node holds
one photon: its float32 position, its original index, and the split axis of
its subtree.  The node's photon is the split: every photon in its left subtree
has ``coord[axis] <= split`` and every photon in its right subtree
``coord[axis] >= split`` (equal coordinates may fall on both sides, which the
search tolerates).  The axis is that of the largest extent of the subtree's
photons (the lowest axis on equal extents), so a degenerate axis (every photon
at y = 0) is never split on while another axis has any extent.

The search (glsl/kd_tree.glsl, one fragment per query) is the classic exact kNN:
descend to the query's side of each split, push the far child on a fixed-size stack
(depth = tree height, a ``#define``) with its cell's per-axis offsets from the query,
keep the k best (float32 squared distance bits, original index) keys in a max-heap
whose top is the pruning radius, and skip a node with its subtree when the squared
distance to its cell exceeds the k-th distance (incremental cell distance, Arya &
Mount; the root's cell is the photons' bounding box, so queries outside it prune
too).  Distances are ``((dx*dx + dy*dy) + dz*dz)`` in float32 with ``d = p - q``
exactly as in glsl/bh_lookup.glsl.  Float rounding is monotonic, so the cell distance
computed the same way is a lower bound of every float32 photon distance in the cell,
and the search returns exactly the k smallest keys over all photons: the float32 brute
force, equal distances ordered by photon index.  Against scipy's cKDTree (float64 on
the same float32 points) distances agree to ~1e-7 relative and the sets agree except
among neighbours tied, or nearly tied within float32 rounding, with the k-th.

llvmpipe ends every loop of a shader invocation silently once 65,535 loop iterations
have run in total (``LOOP_LIMIT``).  The search is therefore one loop of steps that
stops after a step budget with its whole state (next node, cell offsets, stack, heap)
saved to buffers; unfinished queries are resumed in further passes until every search
is complete (``counters['query.passes']``).  Queries run in Hilbert-curve order
(:func:`query_order`) so that the lanes llvmpipe runs together walk similar paths.

Texture: ``nodes`` RGBA32UI, texel ``i`` = (x, y, z float bits, index | axis << 30),
wrapped row by row (blockhash/gl/packing.py, glsl/bh_fetch.glsl).

Measured on the 2-core development machine (llvmpipe, LLVM 15, Mesa 22.3, EGL; other
jobs running, load ~3, so compare within a run), 10^6 caustic-like photons, 262,144 fresh
caustic-like queries, k = 50, medians of 3: build_kdtree 0.64 s (cKDTree build 0.61 s);
query 5.6 s wall, 4.4 s of it the draw (332 nodes visited per query, 2,171 at most, one
pass), beside cKDTree(workers=-1) 1.7 s: 2.5-3.3x slower than cKDTree over several runs.
Queries in the given (random) order instead of Hilbert order: 2-3.5x slower.
"""

from __future__ import annotations

import numpy as np

from blockhash.gl.context import check_gl, draw_timed, get_context, home_framebuffer
from blockhash.gl.kdtree_build import build_kdtree
from blockhash.gl.packing import upload
from blockhash.gl.shaderlib import compile_program
from blockhash.index.records.hilbert import hilbert_keys
from blockhash.validate import as_int, as_points

#: Queries per pass are capped so one draw stays short (llvmpipe runs a draw to completion).
MAX_QUERIES_PER_PASS = 1 << 18
#: The k best live in a local array of 2k uints, whose size the compile time follows
#: (measured here, uncached: k = 50 about 0.3 s, 128 about 2.4 s, 512 about 4.6 s).
MAX_K = 512
#: Width of the query texture and viewport (a power of two, a multiple of 4).
QUERY_WIDTH = 1024
NO_INDEX = 0xFFFFFFFF


# --- search (GLSL) ------------------------------------------------------------------------

#: llvmpipe ends every loop of a shader invocation, silently, once this many loop iterations
#: have run in total (Mesa gallivm LP_MAX_TGSI_LOOP_ITERATIONS, shared by all loops; loops
#: of at most 32 constant iterations are unrolled and do not count).  The search keeps
#: within it by stopping itself after a step budget and resuming in another pass.
LOOP_LIMIT = 65535
#: Iterations kept free beyond those counted in :func:`_loop_reserve`, for loops the
#: compiler might not unroll.
LOOP_MARGIN = 256


def _loop_reserve(k: int, depth: int) -> int:
    """Loop iterations one shader invocation spends outside the search steps (kd_query.frag):
    heap init, load and output (3k), heapsort (k), stack load and save (2 depth)."""
    return 4 * k + 2 * depth + LOOP_MARGIN


#: Compiled programs per (context, defines): every tree of the same size and k shares one.
_programs: dict = {}




def query_order(points: np.ndarray) -> np.ndarray:
    """Permutation that runs ``points`` ((m, 3) float) along a 3D Hilbert curve over their
    bounding box (21 bits per axis); rows with NaN or inf go last, in their given order."""
    finite = np.isfinite(points).all(axis=1)
    good = np.flatnonzero(finite)
    if not len(good):
        return np.arange(len(points))
    f = points[good].astype(np.float64)
    lo, hi = f.min(axis=0), f.max(axis=0)
    scale = np.where(hi > lo, (2.0**32 - 1) / np.where(hi > lo, hi - lo, 1.0), 0.0)
    codes = np.clip((f - lo) * scale, 0, 2.0**32 - 1).astype(np.uint32)
    keys = hilbert_keys(codes)
    return np.concatenate([good[np.argsort(keys, kind="stable")], np.flatnonzero(~finite)])


class GLKdTree:
    """Exact k nearest photons by a kd-tree search in a GLSL fragment shader (paper section 2).

    Parameters
    ----------
    positions : (n, 3) float
        Photon positions (finite, n >= 1), searched as float32; the tree is built with
        :func:`build_kdtree` and kept in ``self.tree``.
    backend : {'auto', 'egl', 'osmesa'}, optional
    step_budget : int, optional
        Search steps (a node visited or skipped) per query and pass; a query that needs
        more is saved and resumed in another pass.  Default: the most that keeps within
        llvmpipe's loop limit (``LOOP_LIMIT``); small values are for tests.
    """

    def __init__(self, positions, *, backend: str | None = None, step_budget: int | None = None):
        if step_budget is not None:
            step_budget = as_int(step_budget, "step_budget", minimum=1, maximum=LOOP_LIMIT,
                                 hint="leave it unset for the largest budget llvmpipe allows")
        self.tree = build_kdtree(positions)
        self.step_budget = step_budget
        self.ctx = get_context(backend)
        with self.ctx:
            self.nodes, self._node_wlog2 = upload(self.ctx, self.tree.texels(), 4, "kd-tree node")
            self._home = home_framebuffer(self.ctx)
        self.counters: dict = {}

    def __len__(self) -> int:
        return len(self.tree)

    def __repr__(self) -> str:
        return (f"GLKdTree(n={len(self):,}, height={self.tree.height}, backend={self.backend!r}, "
                f"step_budget={self.step_budget})")

    @property
    def backend(self) -> str:
        return (self.ctx.extra or {}).get("backend", "?")

    def budget(self, k: int) -> int:
        """Search steps per query and pass for ``k`` neighbours."""
        if self.step_budget is not None:
            return self.step_budget
        return LOOP_LIMIT - _loop_reserve(k, self.tree.height)

    def _program(self, k: int):
        defines = {"KD_K": k, "KD_LEVELS": k.bit_length() - 1, "KD_N": len(self.tree),
                   "KD_DEPTH": self.tree.height, "KD_NODE_W": self._node_wlog2,
                   "KD_QUERY_W": QUERY_WIDTH.bit_length() - 1, "KD_VIEW_W": QUERY_WIDTH}
        key = (id(self.ctx), tuple(defines.items()))
        if key not in _programs:
            _programs[key] = compile_program(self.ctx, "kd_query.frag", defines)
        return _programs[key]

    def query(self, points, k: int = 1, *, spatial_order: bool = True):
        """The exact k nearest photons of each point, like ``scipy.spatial.cKDTree.query``.

        Parameters
        ----------
        points : (m, 3) float
            Query points, searched as float32; rows with NaN or inf get no neighbours.
        k : int
            1 <= k <= MAX_K; k may exceed n (the missing neighbours are inf and n).
        spatial_order : bool
            Run the queries in Hilbert-curve order (:func:`query_order`) so that neighbouring
            fragments walk similar paths: 2-3.5x faster on llvmpipe than random order.
            The results do not depend on it.

        Returns
        -------
        distances : (m, k) float64
            Nearest first: sqrt of the float32 squared distance; inf where missing.
        indices : (m, k) int64
            Into ``positions``; n where missing.  Equal distances: smaller index first.

        Shapes are never squeezed (k = 1 gives (m, 1)).  ``self.counters`` reports the nodes
        visited per finite query (mean, max), the draws (``query.passes``), the queries
        resumed over all passes after the first, ``gl.draw_seconds``, the wall time of the
        draws alone (no compile, upload, ordering or read-back), and ``gl.gpu_seconds``,
        their GL timer-query time.
        """
        n = len(self.tree)
        k = as_int(k, "k", minimum=1, maximum=MAX_K,
                   hint=f"the shader keeps at most MAX_K={MAX_K} neighbours per query")
        q = as_points(points, "points", dtype=np.float32, finite=False)
        m = len(q)
        keys = np.empty((m, k), dtype=np.uint64)  # (d2 bits, index) pairs, in run order
        visits = np.zeros(m, dtype=np.uint32)
        info = self.ctx.info
        ssbo = info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)
        per_pass = max(1, min(MAX_QUERIES_PER_PASS, ssbo // (8 * k),
                              ssbo // (16 * self.tree.height)))
        budget = self.budget(k)
        self.counters = {"query.points": float(m), "query.passes": 0.0, "query.resumed": 0.0,
                         "gl.draw_seconds": 0.0, "gl.gpu_seconds": 0.0}
        order = query_order(q) if spatial_order else None
        qo = q if order is None else q[order]
        with self.ctx:
            for first in range(0, m, per_pass):
                stop = min(m, first + per_pass)
                self._search(qo[first:stop], k, budget, keys[first:stop], visits[first:stop])
        if order is not None:  # back to the caller's order
            ran, keys = keys, np.empty_like(keys)
            keys[order] = ran
            visits[order] = visits.copy()
        pairs = keys.view(np.uint32).reshape(m, k, 2)
        missing = pairs[..., 1] == NO_INDEX
        distances = np.sqrt(pairs.view(np.float32)[..., 0], dtype=np.float64)
        distances[missing] = np.inf
        indices = pairs[..., 1].astype(np.int64)
        indices[missing] = n
        finite = np.isfinite(q).all(axis=1)
        self.counters["query.nodes.mean"] = float(visits[finite].mean()) if finite.any() else 0.0
        self.counters["query.nodes.max"] = float(visits.max()) if m else 0.0
        return distances, indices

    def _search(self, q, k, budget, keys_out, visits_out):
        """Run passes over ``q`` until every search is complete, resuming the unfinished
        ones from their saved state; results go to ``keys_out`` and ``visits_out``."""
        rows = np.arange(len(q))
        state, stack = self._run(q, k, budget, None, keys_out)
        while True:
            done = state[:, 3] == 1
            visits_out[rows[done]] = state[done, 2]
            self.counters["query.passes"] += 1.0
            if done.all():
                return
            rows, q = rows[~done], q[~done]
            saved = (keys_out[rows], state[~done], stack[~done])
            self.counters["query.resumed"] += float(len(rows))
            keys = np.empty((len(rows), k), dtype=np.uint64)
            state, stack = self._run(q, k, budget, saved, keys)
            keys_out[rows] = keys  # unfinished rows hold their heap until a later pass

    def _run(self, q, k, budget, saved, keys_out):
        """One draw over ``q``: fresh searches, or those in ``saved`` (keys, state, stack)
        resumed.  Writes the keys (sorted, or the heap of an unfinished search) into
        ``keys_out`` and returns the state (m, 8) and, if any search is unfinished, the
        stacks (m, depth, 4)."""
        ctx = self.ctx
        m = len(q)
        depth = self.tree.height
        view_h = 4 * -(-m // (16 * (QUERY_WIDTH // 4)))
        rows = -(-m // QUERY_WIDTH)
        grid = np.zeros((rows * QUERY_WIDTH, 4), dtype=np.float32)
        grid[:m, :3] = q
        qtex = ctx.texture((QUERY_WIDTH, rows), 4, grid.view(np.uint32).tobytes(), dtype="u4")
        qtex.filter = (ctx.NEAREST, ctx.NEAREST)
        if saved is None:
            results = ctx.buffer(reserve=m * k * 8)
            states = ctx.buffer(reserve=m * 32)
            stacks = ctx.buffer(reserve=m * depth * 16)
        else:
            results = ctx.buffer(np.ascontiguousarray(saved[0]).tobytes())
            states = ctx.buffer(np.ascontiguousarray(saved[1]).tobytes())
            stacks = ctx.buffer(np.ascontiguousarray(saved[2]).tobytes())
        color = ctx.renderbuffer((QUERY_WIDTH, view_h), 4, dtype="f1")
        fbo = ctx.framebuffer(color_attachments=[color])
        check_gl(ctx, f"allocating buffers for {m:,} queries x k={k}")
        try:
            prog = self._program(k)
            prog["kd_count"].value = m
            prog["kd_resume"].value = saved is not None
            prog["kd_budget"].value = budget
            prog["kd_lo"].value = tuple(float(x) for x in self.tree.lo)
            prog["kd_hi"].value = tuple(float(x) for x in self.tree.hi)
            for unit, (name, tex) in enumerate((("kd_nodes", self.nodes), ("kd_queries", qtex))):
                tex.use(location=unit)
                prog[name].value = unit
            for binding, buf in enumerate((results, states, stacks)):
                buf.bind_to_storage_buffer(binding)
            wall, gpu = draw_timed(ctx, prog, fbo, (QUERY_WIDTH, view_h))
            self.counters["gl.draw_seconds"] += wall
            self.counters["gl.gpu_seconds"] += gpu
            check_gl(ctx, "the kd-tree search draw")
            state = np.frombuffer(states.read(), dtype=np.uint32).reshape(m, 8).copy()
            results.read_into(keys_out)
            stack = None
            if not (state[:, 3] == 1).all():
                stack = np.frombuffer(stacks.read(), dtype=np.uint32).reshape(m, depth, 4)
            return state, stack
        finally:
            # moderngl rebinds its current framebuffer after creating one: never leave a
            # framebuffer that is about to be released current (see lookup.py).
            self._home.use()
            for obj in (qtex, results, states, stacks, fbo, color):
                obj.release()

    def release(self):
        """Free the node texture.  The programs and the home framebuffer stay with the
        context: trees of the same size share them."""
        with self.ctx:
            self._home.use()
            self.nodes.release()
