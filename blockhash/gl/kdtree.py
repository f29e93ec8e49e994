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

The search (glsl/kd_tree.glsl) is the classic exact kNN: descend to the side of
the query, push the far child with its squared plane distance on a fixed-size
stack (depth = tree height, a ``#define``), keep the k best
(float32 squared distance bits, original index) keys, and pop a far child only
if its plane distance does not exceed the current k-th distance.  Distances are
``((dx*dx + dy*dy) + dz*dz)`` in float32 with ``d = p - q`` exactly as in
glsl/bh_lookup.glsl; equal distances are ordered by original photon index.
Since float rounding is monotonic, the float32 squared plane distance of a far
child is a lower bound of the float32 squared distance of every photon below
it, so the pruning never drops a key that belongs to the k best: the result is
the exact k smallest keys over all photons (the float32 brute force).

Texture: ``nodes`` RGBA32UI, texel ``i`` = (x, y, z bits, index | axis << 30),
wrapped row by row (blockhash/gl/packing.py, glsl/bh_fetch.glsl).

Measured on the 2-core development machine (llvmpipe; see the module's report)::

    build_kdtree, 10^6 caustic-like photons: see KdTree.build_seconds
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numba
import numpy as np

from ..errors import CapacityError, InputError
from ..validate import as_int, as_points
from .context import check_gl, get_context
from .packing import upload
from .shaderlib import compile_program

#: The node's original index shares a 32-bit word with the split axis (2 bits).
AXIS_SHIFT = 30
MAX_PHOTONS = 1 << AXIS_SHIFT
#: Queries per pass are capped so one draw stays short (llvmpipe runs a draw to completion).
MAX_QUERIES_PER_PASS = 1 << 18
#: The k-best list lives in a local array of 2k uints; compile time grows fast with its size
#: (DESIGN.md: 512 elements 0.25 s, 2048 elements 3.9 s), so k is bounded.
MAX_K = 512
#: Width of the query texture and viewport (a power of two, a multiple of 4).
QUERY_WIDTH = 1024
NO_INDEX = 0xFFFFFFFF


# --- build (CPU) --------------------------------------------------------------------------

@numba.njit(cache=True, inline="always")
def _left_size(n):
    """Nodes in the left subtree of a complete (left-balanced) tree of ``n`` nodes."""
    if n <= 1:
        return 0
    h = 0
    while (2 << h) <= n:  # h = floor(log2(n)): depth of the last level
        h += 1
    last = n - ((1 << h) - 1)  # nodes on the last level, 1 .. 2^h
    half = 1 << (h - 1)  # of which the left subtree can hold at most half
    return (half - 1) + min(last, half)


@numba.njit(cache=True)
def _select(perm, lo, hi, m, coord):
    """Partially sort perm[lo:hi] by coord[perm] so that perm[m] is the (m - lo)-th smallest,
    everything before it <= and everything after it >= (Hoare quickselect, median of three)."""
    while hi - lo > 1:
        mid = (lo + hi - 1) >> 1
        a, b, c = coord[perm[lo]], coord[perm[mid]], coord[perm[hi - 1]]
        if a < b:
            pivot = b if b < c else (c if a < c else a)
        else:
            pivot = a if a < c else (c if b < c else b)
        i, j = lo, hi - 1
        while i <= j:
            while coord[perm[i]] < pivot:
                i += 1
            while coord[perm[j]] > pivot:
                j -= 1
            if i <= j:
                t = perm[i]
                perm[i] = perm[j]
                perm[j] = t
                i += 1
                j -= 1
        # now perm[lo:j+1] <= pivot, perm[i:hi] >= pivot, perm[j+1:i] == pivot
        if m <= j:
            hi = j + 1
        elif m >= i:
            lo = i
        else:
            return


@numba.njit(cache=True)
def _build(pos):
    n = pos.shape[0]
    perm = np.arange(n, dtype=np.int64)
    node_index = np.empty(n, dtype=np.int64)
    node_axis = np.zeros(n, dtype=np.uint8)
    # explicit work stack of (node, lo, hi); depth-first keeps it at most 2 * height
    stack = np.empty((128, 3), dtype=np.int64)
    sp = 0
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, n
    sp = 1
    coord = np.empty(n, dtype=np.float32)
    while sp > 0:
        sp -= 1
        node, lo, hi = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        cnt = hi - lo
        m = lo + _left_size(cnt)
        axis = 0
        if cnt > 1:
            lox, loy, loz = np.inf, np.inf, np.inf
            hix, hiy, hiz = -np.inf, -np.inf, -np.inf
            for t in range(lo, hi):
                p = perm[t]
                x, y, z = pos[p, 0], pos[p, 1], pos[p, 2]
                lox, hix = min(lox, x), max(hix, x)
                loy, hiy = min(loy, y), max(hiy, y)
                loz, hiz = min(loz, z), max(hiz, z)
            ex, ey, ez = hix - lox, hiy - loy, hiz - loz
            if ey > ex:
                axis = 1
                if ez > ey:
                    axis = 2
            elif ez > ex:
                axis = 2
            for t in range(lo, hi):
                coord[perm[t]] = pos[perm[t], axis]
            _select(perm, lo, hi, m, coord)
        node_index[node] = perm[m]
        node_axis[node] = axis
        if m + 1 < hi:
            stack[sp, 0], stack[sp, 1], stack[sp, 2] = 2 * node + 2, m + 1, hi
            sp += 1
        if lo < m:
            stack[sp, 0], stack[sp, 1], stack[sp, 2] = 2 * node + 1, lo, m
            sp += 1
    return node_index, node_axis


@dataclass(frozen=True, repr=False)
class KdTree:
    """A left-balanced kd-tree of N photons in N heap-ordered nodes (paper section 2).

    Attributes
    ----------
    positions : (n, 3) float32      node i's photon position (= its split value on ``axis[i]``)
    index : (n,) int64              node i's photon, as an index into the build positions
    axis : (n,) uint8               split axis of node i's subtree (0 for leaves)
    height : int                    levels of the tree, floor(log2 n) + 1 (the stack depth)
    build_seconds : float
    """

    positions: np.ndarray
    index: np.ndarray
    axis: np.ndarray
    height: int
    build_seconds: float = field(default=0.0, compare=False)

    def __len__(self) -> int:
        return len(self.index)

    @property
    def nbytes(self) -> int:
        """Bytes of the GL node texture payload (16 per node)."""
        return 16 * len(self)

    def texels(self) -> np.ndarray:
        """(n, 4) uint32 node texels: x, y, z float bits and index | axis << 30."""
        out = np.empty((len(self), 4), dtype=np.uint32)
        out[:, :3] = self.positions.view(np.uint32)
        out[:, 3] = self.index.astype(np.uint32) | (self.axis.astype(np.uint32) << AXIS_SHIFT)
        return out

    def __repr__(self) -> str:
        return (f"KdTree(n={len(self):,}, height={self.height}, "
                f"build_seconds={self.build_seconds:.3f})")


def build_kdtree(positions) -> KdTree:
    """Build the balanced kd-tree of ``positions`` on the CPU.

    Parameters
    ----------
    positions : (n, 3) float
        Photon positions, finite, n >= 1; converted to float32 (the search runs in
        float32: pass ``BlockHashIndex.positions`` to search the photons that the Block
        Hashing index searches).

    Median split along the axis of largest extent of each subtree's photons; the
    left-balanced layout makes the tree complete, so node ``i`` has children
    ``2i + 1`` and ``2i + 2`` where those are below n.  Compiled with numba.
    """
    pos = as_points(positions, "positions", dtype=np.float32, allow_empty=False)
    n = len(pos)
    if n >= MAX_PHOTONS:
        raise CapacityError(f"positions has {n:,} photons; the kd-tree stores indices in "
                            f"{AXIS_SHIFT} bits, so at most {MAX_PHOTONS - 1:,}; use fewer photons")
    t0 = time.perf_counter()
    index, axis = _build(pos)
    seconds = time.perf_counter() - t0
    return KdTree(positions=pos[index], index=index, axis=axis, height=int(n).bit_length(),
                  build_seconds=seconds)


# --- search (GLSL) ------------------------------------------------------------------------

#: llvmpipe ends every loop of a shader invocation, silently, once this many loop iterations
#: have run in total (Mesa gallivm LP_MAX_TGSI_LOOP_ITERATIONS, shared by all loops; loops
#: of at most 32 constant iterations are unrolled and do not count).  The search keeps
#: within it by stopping itself after a step budget and resuming in another pass.
LOOP_LIMIT = 65535
#: Iterations kept free for the fixed-length loops around the search, beyond the ones
#: counted in :func:`_loop_reserve` (a margin for loops the compiler does not unroll).
LOOP_MARGIN = 256


def _loop_reserve(k: int, depth: int) -> int:
    """Loop iterations one shader invocation spends outside the search steps (kd_query.frag):
    heap init and load (2k), stack load and save (2 depth), the end of a sift and the loop
    exit (log2 k + 2), heapsort ((k - 1)(log2 k + 1)) and the output (k)."""
    lg = max(1, (k - 1).bit_length())
    return 3 * k + 2 * depth + lg + 2 + (k - 1) * (lg + 1) + LOOP_MARGIN


class GLKdTree:
    """Exact k nearest photons by a kd-tree search in a GLSL fragment shader (paper section 2).

    Parameters
    ----------
    positions : (n, 3) float
        Photon positions (finite, n >= 1), searched as float32; the tree is built with
        :func:`build_kdtree` and kept in ``self.tree``.
    backend : {'auto', 'egl', 'osmesa'}, optional
    step_budget : int, optional
        Search steps (node visits, stack pops, heap sift levels) per query and pass; a query
        that needs more is saved and resumed in another pass.  Default: the most that keeps
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
            self._home_color = self.ctx.renderbuffer((1, 1), 4, dtype="f1")
            self._home = self.ctx.framebuffer(color_attachments=[self._home_color])
            check_gl(self.ctx, "allocating the kd-tree's home framebuffer")
        self._programs: dict = {}
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
        defines = {"KD_K": k, "KD_N": len(self.tree), "KD_DEPTH": self.tree.height,
                   "KD_NODE_W": self._node_wlog2, "KD_QUERY_W": QUERY_WIDTH.bit_length() - 1,
                   "KD_VIEW_W": QUERY_WIDTH}
        key = tuple(defines.items())
        if key not in self._programs:
            self._programs[key] = compile_program(self.ctx, "kd_query.frag", defines)
        return self._programs[key]

    def query(self, points, k: int = 1):
        """The exact k nearest photons of each point, like ``scipy.spatial.cKDTree.query``.

        Parameters
        ----------
        points : (m, 3) float
            Query points, searched as float32; rows with NaN or inf get no neighbours.
        k : int
            1 <= k <= MAX_K; k may exceed n (the missing neighbours are inf and n).

        Returns
        -------
        distances : (m, k) float64
            Nearest first: sqrt of the float32 squared distance; inf where missing.
        indices : (m, k) int64
            Into ``positions``; n where missing.  Equal distances: smaller index first.

        Shapes are never squeezed (k = 1 gives (m, 1)).  ``self.counters`` reports the mean
        nodes visited per finite query, and the passes and queries that were resumed.
        """
        n = len(self.tree)
        k = as_int(k, "k", minimum=1, maximum=MAX_K,
                   hint=f"the shader keeps at most MAX_K={MAX_K} neighbours per query")
        q = as_points(points, "points", dtype=np.float32, finite=False)
        m = len(q)
        pairs = np.empty((m, k, 2), dtype=np.uint32)
        visits = np.zeros(m, dtype=np.uint32)
        info = self.ctx.info
        ssbo = info.get("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 1 << 27)
        per_pass = max(1, min(MAX_QUERIES_PER_PASS, ssbo // (8 * k), ssbo // (8 * self.tree.height)))
        budget = self.budget(k)
        self.counters = {"query.points": float(m), "query.passes": 0.0, "query.resumed": 0.0}
        with self.ctx:
            for first in range(0, m, per_pass):
                stop = min(m, first + per_pass)
                self._search(q[first:stop], k, budget, pairs[first:stop], visits[first:stop])
        idx = pairs[..., 1].astype(np.int64)
        found = idx != NO_INDEX
        d2 = pairs[..., 0].copy().view(np.float32)
        distances = np.where(found, np.sqrt(d2.astype(np.float64)), np.inf)
        indices = np.where(found, idx, n)
        finite = np.isfinite(q).all(axis=1)
        self.counters["query.nodes.mean"] = float(visits[finite].mean()) if finite.any() else 0.0
        self.counters["query.nodes.max"] = float(visits.max()) if m else 0.0
        return distances, indices

    def _search(self, q, k, budget, pairs_out, visits_out):
        """Run passes over ``q`` until every search is complete (resuming the unfinished)."""
        rows = np.arange(len(q))
        saved = None
        while len(rows):
            pairs, state, stack = self._run(q[rows], k, budget, saved)
            done = state[:, 3] == 1
            pairs_out[rows[done]] = pairs[done]
            visits_out[rows[done]] = state[done, 2]
            self.counters["query.passes"] += 1.0
            if saved is not None:
                self.counters["query.resumed"] += float(len(rows))
            rows = rows[~done]
            saved = (pairs[~done], state[~done], stack[~done]) if len(rows) else None

    def _run(self, q, k, budget, saved):
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
            states = ctx.buffer(reserve=m * 16)
            stacks = ctx.buffer(reserve=m * depth * 8)
        else:
            results = ctx.buffer(np.ascontiguousarray(saved[0]).tobytes())
            states = ctx.buffer(np.ascontiguousarray(saved[1]).tobytes())
            stacks = ctx.buffer(np.ascontiguousarray(saved[2]).tobytes())
        color = ctx.renderbuffer((QUERY_WIDTH, view_h), 4, dtype="f1")
        fbo = ctx.framebuffer(color_attachments=[color])
        check_gl(ctx, f"allocating buffers for {m:,} queries x k={k}")
        vao = None
        try:
            prog = self._program(k)
            prog["kd_count"].value = m
            prog["kd_resume"].value = saved is not None
            prog["kd_budget"].value = budget
            for unit, (name, tex) in enumerate({"kd_nodes": self.nodes, "kd_queries": qtex}.items()):
                tex.use(location=unit)
                prog[name].value = unit
            for binding, buf in enumerate((results, states, stacks)):
                buf.bind_to_storage_buffer(binding)
            fbo.use()
            fbo.viewport = (0, 0, QUERY_WIDTH, view_h)
            vao = ctx.vertex_array(prog, [])
            vao.render(mode=ctx.TRIANGLES, vertices=3)
            ctx.finish()
            check_gl(ctx, "the kd-tree search draw")
            state = np.frombuffer(states.read(), dtype=np.uint32).reshape(m, 4).copy()
            pairs = np.frombuffer(results.read(), dtype=np.uint32).reshape(m, k, 2)
            stack = None
            if not (state[:, 3] == 1).all():
                stack = np.frombuffer(stacks.read(), dtype=np.uint32).reshape(m, depth, 2)
            return pairs, state, stack
        finally:
            # moderngl rebinds its current framebuffer after creating one: never leave a
            # framebuffer that is about to be released current (see lookup.py).
            self._home.use()
            for obj in (vao, qtex, results, states, stacks, fbo, color):
                if obj is not None:
                    obj.release()

    def release(self):
        with self.ctx:
            self._home.use()
            self.nodes.release()
            self._home.release()
            self._home_color.release()
            for prog in self._programs.values():
                prog.release()
        self._programs.clear()
