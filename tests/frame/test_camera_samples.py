"""The camera's samples over passes: each pixel covered evenly."""

import numpy as np

from blockhash.frame.subpixel import pass_offsets


def test_camera_samples_cover_each_pixel_evenly_over_passes():
    """64 passes put one sample in each cell of an 8 x 8 grid of the pixel about once: the
    R2 sequence's low discrepancy (random points leave ~37% of cells empty)."""
    u = np.stack([pass_offsets(5, 4, p, 1)[0] for p in range(64)])
    v = np.stack([pass_offsets(5, 4, p, 1)[1] for p in range(64)])
    assert ((u >= 0) & (u < 1) & (v >= 0) & (v < 1)).all()
    cells = (np.floor(u * 8) * 8 + np.floor(v * 8)).astype(int)
    for i in range(4):
        for j in range(5):
            hit = np.bincount(cells[:, i, j], minlength=64)
            assert (hit == 0).sum() <= 12, hit
    a, b = pass_offsets(5, 4, 3, 1), pass_offsets(5, 4, 3, 1)
    assert np.array_equal(a[0], b[0]) and not np.array_equal(a[0], pass_offsets(5, 4, 4, 1)[0])

