"""Block Hashing data as integer textures (paper section 7, steps 2 and 4).

Every array is a 1D sequence of texels stored row by row in a 2D texture whose
width ``W`` is a power of two (the largest not above GL_MAX_TEXTURE_SIZE and
not wider than needed): element ``i`` is texel ``(i mod W, i div W)``
(glsl/bh_fetch.glsl).  Layouts:

============  ========  ====================================================
texture       format    element
============  ========  ====================================================
blocks        RGBA32UI  16 texels per block: the block's 64 words (Figure 4), with its
                        spare words 61-63 holding the block's box (block_boxes)
headers       RG32UI    bucket ``t * buckets + key``: (priority alpha, entries)
refs          R32UI     ``(t * buckets + key) * B + slot``: block reference
thresholds    R32UI     ``t * T + i``: threshold codes (blockhash/index/tables/thresholds.py)
cells         RGBA32UI  cuckoo slot ``i`` of the Hilbert cells: (key hi, key lo, first slot,
                        count) (blockhash/index/lookups/cells.py)
points        RGBA32F   photon slot ``s`` (block order): its decoded float32 position, 0
boxes         RGBA32UI  2 texels per adaptive node ``t * (T / 2) + i``: (float32 bits of
                        lo x, y, z, 1 if the box holds photons else 0), (hi x, y, z, 0)
                        (blockhash/index/tables/node_boxes.py; one zero texel for a grid layout)
============  ========  ====================================================

A map that does not fit (more rows than GL_MAX_TEXTURE_SIZE) is refused
before anything is allocated; allocations are checked with ``ctx.error``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockhash.errors import CapacityError
from blockhash.gl import strict
from blockhash.gl.context import check_gl
from blockhash.index.records.blocks import COUNT_WORD, block_boxes  # noqa: F401 (block_boxes: re-exported)


def texture_shape(elements: int, max_size: int) -> tuple[int, int, int]:
    """(width, height, log2 width) for ``elements`` texels, or CapacityError."""
    elements = max(int(elements), 1)
    wlog2 = min(int(max_size).bit_length() - 1, max(0, (elements - 1).bit_length()))
    width = 1 << wlog2
    height = -(-elements // width)
    if height > max_size:
        raise CapacityError(
            f"{elements:,} texels need {width:,} x {height:,} > GL_MAX_TEXTURE_SIZE={max_size:,} "
            "rows; use fewer photons, or a smaller index (fewer tables L, buckets P or slots B)")
    return width, height, wlog2


def upload(ctx, data: np.ndarray, components: int, what: str, *, dtype: str = "u4",
           pooled: bool = False):
    """Upload ``data`` ((n, components) or (n,)) as a wrapped 2D texture; returns (texture, log2 W).
    ``pooled``: into a texture of the context's pool (:mod:`.pool`; hand it back with
    :func:`.pool.give_back`), with at least the rows needed."""
    max_size = ctx.info["GL_MAX_TEXTURE_SIZE"]
    flat = np.ascontiguousarray(data).reshape(-1, components)
    width, height, wlog2 = texture_shape(len(flat), max_size)
    if pooled:
        from blockhash.gl.pool import pooled_texture

        tex = pooled_texture(ctx, what, width, height, components, dtype)
    else:
        tex = ctx.texture((width, height), components, dtype=dtype)
        strict.poison(tex)
    # The full rows straight from ``data`` (no padded copy of the whole array); the last
    # row, padded with zeros, on its own.
    full = len(flat) // width
    if full:
        tex.write(flat[:full * width], viewport=(0, 0, width, full))
    if full < height:
        last = np.zeros((width, components), dtype=flat.dtype)
        last[:len(flat) - full * width] = flat[full * width:]
        tex.write(last, viewport=(0, full, width, 1))
    check_gl(ctx, f"allocating the {what} texture ({width} x {height} x {components} x 4 bytes)")
    tex.filter = (ctx.NEAREST, ctx.NEAREST)
    tex.repeat_x = tex.repeat_y = False
    return tex, wlog2


@dataclass
class PackedIndex:
    """The GL textures of one BlockHashIndex in one context."""

    blocks: object
    headers: object
    refs: object
    thresholds: object
    boxes: object
    cells: object
    points: object
    widths: dict
    with_cells: bool = False

    def release(self):
        for tex in (self.blocks, self.headers, self.refs, self.thresholds, self.boxes,
                    self.cells, self.points):
            tex.release()


def box_texels(node_boxes) -> np.ndarray:
    """(2 * L * nodes, 4) uint32 texels of the node boxes (the ``boxes`` layout above), or
    one zero texel when there are none (``node_boxes`` None: a grid layout)."""
    if node_boxes is None:
        return np.zeros((1, 4), dtype=np.uint32)
    b = np.ascontiguousarray(node_boxes, dtype=np.float32).reshape(-1, 6)
    out = np.zeros((len(b), 2, 4), dtype=np.uint32)
    out[:, 0, :3] = b[:, :3].view(np.uint32)
    out[:, 0, 3] = b[:, 0] <= b[:, 3]
    out[:, 1, :3] = b[:, 3:].view(np.uint32)
    return out.reshape(-1, 4)


def pack_index(ctx, index) -> PackedIndex:
    """Upload an index's blocks, bucket headers, references, thresholds and node boxes."""
    tables = index.tables
    headers = np.stack([index.priority.astype(np.uint32), tables.entries.astype(np.uint32)], axis=-1)
    refs = tables.refs.astype(np.int64).astype(np.uint32)  # -1 -> 0xFFFFFFFF, past `entries`
    thresholds = index.thresholds if index.thresholds.size else np.zeros((1, 1), dtype=np.uint32)
    words = index.block_words.copy()
    words[:, COUNT_WORD + 1:COUNT_WORD + 4] = block_boxes(words)
    # The cell lookup's textures only where the index queries its cells (params.cells).
    with_cells = bool(getattr(index.params, "cells", False))
    points = np.zeros((len(index) if with_cells else 1, 4), dtype=np.float32)
    if with_cells:
        points[:, :3] = index._positions
    cell_slots = index.cells.slots if with_cells else np.zeros((1, 4), dtype=np.uint32)
    done = []
    try:
        for data, comps, what, dtype in (
                (words.reshape(-1, 4), 4, "photon block", "u4"),
                (headers.reshape(-1, 2), 2, "bucket header", "u4"),
                (refs.reshape(-1), 1, "block reference", "u4"),
                (thresholds.reshape(-1), 1, "threshold", "u4"),
                (box_texels(getattr(index, "node_boxes", None)), 4, "node box", "u4"),
                (cell_slots, 4, "cell", "u4"),
                (points, 4, "photon position", "f4")):
            done.append(upload(ctx, data, comps, what, dtype=dtype))
    except CapacityError:
        for tex, _ in done:
            tex.release()
        raise
    (blocks, wb), (hdr, wh), (ref, wr), (thr, wt), (box, wx), (cel, wc), (pts, wp) = done
    return PackedIndex(blocks=blocks, headers=hdr, refs=ref, thresholds=thr, boxes=box,
                       cells=cel, points=pts, with_cells=with_cells,
                       widths={"BH_BLK_W": wb, "BH_HDR_W": wh, "BH_REF_W": wr, "BH_THR_W": wt,
                               "BH_BOX_W": wx, "BH_CELL_W": wc, "BH_PT_W": wp})


def set_photon_box(program, quantizer, power_scale) -> None:
    """The photon box (glsl/bh_box.glsl: ``bh_lo``, ``bh_step``, ``bh_inv_step``) and the
    power scale (``bh_power_scale``) as exact float32 values, each where ``program`` uses it
    (the nearest-box-first walk quantizes no query: no ``bh_inv_step``)."""
    for name, value in (("bh_lo", quantizer.lo), ("bh_step", quantizer.step),
                        ("bh_inv_step", quantizer.inv_step)):
        if name in program:
            program[name].value = tuple(float(x) for x in value)
    if "bh_power_scale" in program:
        program["bh_power_scale"].value = float(power_scale)
