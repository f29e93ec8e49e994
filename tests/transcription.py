"""Plain-Python transcriptions of the reference query (blockhash/index/lookups/hash.py), the
oracles that the tests hold the numba reference and the shader to."""

import numpy as np

from blockhash.index.tables.thresholds import PROBE_CUTS, ThresholdLayout, hash_codes


def descend(row, code, step):
    """The adaptive layout's descent in plain Python: (bucket, cuts), cuts the path's
    (gap, axis, code across) nearest first, ties in path order."""
    i, cuts = 0, []
    while not int(row[2 * i + 1]) & 4:
        meta, t = int(row[2 * i + 1]), int(row[2 * i])
        a = meta & 3
        right = int(code[a]) >= t
        gap = np.float32(np.float32(abs(int(code[a]) - t) >> 8) * np.float32(step[a]))
        cuts.append((gap, a, t - 1 if right else t))
        i = (meta >> 3) + int(right)
    cuts.sort(key=lambda c: c[0])
    return int(row[2 * i + 1]) >> 3, cuts[:PROBE_CUTS]


def visited_buckets(index, q):
    """(table, bucket) in the order section 4.4 visits them, for one query, in plain Python:
    by priority alpha; for the adaptive layout, tables deepest first and then the probes
    across each table's nearest cuts (blockhash/index/lookups/hash.py steps 2 and 4)."""
    prm = index.params
    qf = np.asarray(q, dtype=np.float32)[None, :]
    code = index.quantizer.quantize_query(qf)[0]
    buckets = []  # (table, key) in visiting order
    if prm.layout == ThresholdLayout.ADAPTIVE:
        step = index.quantizer.step.astype(np.float32)
        found = [descend(index.thresholds[t], code, step) for t in range(prm.L)]
        order = sorted(range(prm.L), key=lambda t: (-found[t][1][0][0] if found[t][1] else -np.inf, t))
        buckets = [(t, found[t][0]) for t in order]
        for j in range(PROBE_CUTS):
            for t in order:
                if j < len(found[t][1]):
                    probe = code.copy()
                    _, a, across = found[t][1][j]
                    probe[a] = across
                    key = descend(index.thresholds[t], probe, step)[0]
                    if key != found[t][0]:
                        buckets.append((t, key))
    else:
        keys = hash_codes(code[None, :], index.thresholds, prm.P, prm.layout)[:, 0]
        order = sorted(range(prm.L), key=lambda t: (index.priority[t, keys[t]], t))
        buckets = [(t, keys[t]) for t in order]
    return buckets


def examined_blocks(index, q, k, A):
    """The blocks the reference takes for one query: references in slot order, duplicates
    skipped, while fewer than A * k candidates and L * B blocks were taken (steps 3, 4);
    the default preset: the blocks its nearest-box-first walk takes (the A * k cap alone)."""
    if index.params.best_first:
        return walk(index, q, k, A)[1]
    taken, count = [], 0
    most = index.params.L * index.params.B
    for t, key in visited_buckets(index, q):
        for blk in index.tables.refs[t, key]:
            if count >= A * k or blk < 0 or len(taken) >= most:
                break
            if blk in taken:
                continue
            taken.append(int(blk))
            count += int(index.starts[blk + 1] - index.starts[blk])
    return taken


def box_distance(box, q):
    """float32 squared distance from q to a node box, the walk's operations one by one."""
    g = [max(max(np.float32(box[a] - q[a]), np.float32(q[a] - box[3 + a])), np.float32(0))
         for a in range(3)]
    return np.float32(np.float32(np.float32(g[0] * g[0]) + np.float32(g[1] * g[1]))
                      + np.float32(g[2] * g[2]))


def block_gap2(words, q, lo, step):
    """The walk's block culling bound (glsl/bh_blocks.glsl bh_block_gap2) in plain Python:
    ``words`` a block's three box words (blockhash/index/records/blocks.py block_boxes), one
    float32 rounding per operation."""
    f = np.float32
    g = []
    for a in range(3):
        w = int(words[a])
        blo = f(lo[a] + f(f((w & 0xFFFF) << 16) * step[a]))
        bhi = f(lo[a] + f(f((w & 0xFFFF0000) | 0xFFFF) * step[a]))
        margin = f(f(abs(lo[a]) + f(step[a] * f(2.0 ** 32))) * f(2.0 ** -18))
        g.append(max(f(max(f(blo - q[a]), f(q[a] - bhi)) - margin), f(0)))
    s = f(f(f(g[0] * g[0]) + f(g[1] * g[1])) + f(g[2] * g[2]))
    return f(s * f(1 - 2.0 ** -16))


def walked_query(index, q, k, A, trees=None):
    """The nearest-box-first walk (blockhash/index/lookups/walk.py) in plain Python, with an
    unbounded sorted queue (the real one's capacity never binds on small maps), seeded with
    the first ``trees`` tables (default: the params' for k: all L below its walk_floor), the
    cap of A * max(k, walk_floor) candidates alone ending it (no block cap): the k nearest (slots, squared distances) of the photons of
    the buckets it reaches; once k are held, a block whose :func:`block_gap2` is above 0
    and above the k-th distance is culled (not taken, not counted)."""
    best, _ = walk(index, q, k, A, trees)
    return [s for _, s in best], [v for v, _ in best]


def walk(index, q, k, A, trees=None):
    """:func:`walked_query`'s walk: (the k best (d2, slot), sorted; the blocks taken)."""
    prm = index.params
    trees = prm.walk_tables(k) if trees is None else min(trees, prm.L)
    # The candidate cap: A * k, or A * walk_floor below the params' floor.
    cap = A * max(k, prm.walk_floor)
    qf = np.asarray(q, dtype=np.float32)
    boxes, rows = index.node_boxes, index.thresholds
    nn = boxes.shape[1]
    from blockhash.index.lookups.walk import MAX_LEAVES, MAX_POPS
    from blockhash.index.records.blocks import block_boxes

    cboxes = block_boxes(index.block_words)
    lo = index.quantizer.lo.astype(np.float32)
    step = index.quantizer.step.astype(np.float32)

    def nonempty(t, i):
        return boxes[t, i, 0] <= boxes[t, i, 3]

    queue = sorted((box_distance(boxes[t, 0], qf), t * nn) for t in range(trees) if nonempty(t, 0))
    best, taken, count, leaves = [], [], 0, 0   # best: sorted (d2, slot), at most k
    for _ in range(MAX_POPS):
        if count >= cap or not queue:
            break
        d, node = queue.pop(0)
        kth = best[-1][0] if len(best) == k else np.float32(np.inf)
        if len(best) == k and d > kth:
            break
        t, i = divmod(node, nn)
        meta = int(rows[t, 2 * i + 1])
        if meta & 4:
            if leaves >= MAX_LEAVES:
                break
            leaves += 1
            for blk in index.tables.refs[t, meta >> 3]:
                if count >= cap or blk < 0:
                    break
                if blk in taken:
                    continue
                if len(best) == k:
                    gap = block_gap2(cboxes[blk], qf, lo, step)
                    if gap > 0 and gap > best[-1][0]:
                        continue
                taken.append(int(blk))
                for s in range(index.starts[blk], index.starts[blk + 1]):
                    count += 1
                    p = index._positions[s] - qf
                    d2 = np.float32(np.float32(p[0] * p[0] + p[1] * p[1]) + p[2] * p[2])
                    best = sorted(best + [(d2, s)])[:k]
            continue
        c = meta >> 3
        for child in (c, c + 1):
            if nonempty(t, child):
                dc = box_distance(boxes[t, child], qf)
                if len(best) < k or dc <= kth:
                    queue.append((dc, t * nn + child))
        queue.sort()
    return best, taken


def transcribed_query(index, q, k, A):
    """Section 4.4 as written: the k nearest of the examined photons, ties by slot (the
    default preset: the nearest-box-first walk, :func:`walked_query`)."""
    if index.params.best_first:
        return walked_query(index, q, k, A)
    qf = np.asarray(q, dtype=np.float32)[None, :]
    cand = [s for blk in examined_blocks(index, q, k, A)
            for s in range(index.starts[blk], index.starts[blk + 1])]
    p = index._positions[cand]
    d = p - qf[0]
    d2 = (d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2]
    best = sorted(zip(d2.tolist(), cand))[:k]
    return [s for _, s in best], [v for v, _ in best]
