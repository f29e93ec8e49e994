"""Plain-Python transcriptions of the reference query (blockhash/index/query.py), the
oracles that the tests hold the numba reference and the shader to."""

import numpy as np

from blockhash.index.thresholds import PROBE_CUTS, ThresholdLayout, hash_codes


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
    across each table's nearest cuts (blockhash/index/query.py steps 2 and 4)."""
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
    skipped, while fewer than A * k candidates and L * B blocks were taken (steps 3, 4)."""
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


def transcribed_query(index, q, k, A):
    """Section 4.4 as written: the k nearest of the examined photons, ties by slot."""
    qf = np.asarray(q, dtype=np.float32)[None, :]
    cand = [s for blk in examined_blocks(index, q, k, A)
            for s in range(index.starts[blk], index.starts[blk + 1])]
    p = index._positions[cand]
    d = p - qf[0]
    d2 = (d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2]
    best = sorted(zip(d2.tolist(), cand))[:k]
    return [s for _, s in best], [v for v, _ in best]
