"""The axis probe's sorting network gives what sorting the probed codes as floats gives."""

import numpy as np
import pytest

from blockhash.index.tables.probe import AXIS_PROBE, PROBE_SLOTS, spreads


def _plain(c, lo, hi, scale, out):
    """The probe written out: strided rows, each axis' codes sorted as float64."""
    n = hi - lo
    m = min(n, AXIS_PROBE)
    rows = [lo + (r * n) // m for r in range(m)]
    for a in range(3):
        v = np.sort(c[rows, a].astype(np.float64))
        out[a, 0] = (v[(3 * m) // 4] - v[m // 4]) * scale[a]
        out[a, 1] = (v[(19 * m) // 20] - v[m // 20]) * scale[a]
        out[a, 2] = (v[m - 1] - v[0]) * scale[a]
        out[a, 3] = 0.0
        for r in range(1, m):
            if (v[r] - v[r - 1]) * scale[a] > out[a, 3]:
                out[a, 3] = (v[r] - v[r - 1]) * scale[a]
                out[a, 4], out[a, 5] = v[r - 1], v[r]
    return out


@pytest.mark.parametrize("scale", [(2.3e-10, 7e-11, 1.0), (0.0, -1.0, np.inf), (1e-300, 1e300, np.nan)])
def test_spreads_match_a_plain_sort(scale):
    rng = np.random.default_rng(3)
    scale = np.array(scale)
    v = np.empty((PROBE_SLOTS, 4), dtype=np.uint32)
    for trial in range(300):
        n = int(rng.integers(2, 400))
        top = [2**32, 50, 3][trial % 3]  # spread codes, few codes, ties everywhere
        c = np.zeros((n + 7, 4), dtype=np.uint32)
        c[:, :3] = rng.integers(0, top, (n + 7, 3), dtype=np.uint64)
        c[rng.random(n + 7) < 0.3, 1] = np.uint32(0xFFFFFFFF)  # codes equal to the padding
        fast = spreads(c, 5, 5 + n, scale, v, np.full((3, 6), 7.0))
        with np.errstate(invalid="ignore", over="ignore"):
            plain = _plain(c, 5, 5 + n, scale, np.full((3, 6), 7.0))
        np.testing.assert_array_equal(fast, plain)
