"""The photon records' direction and normal words in one compiled pass (the fast path of
:meth:`blockhash.index.records.codec.PhotonRecords.encode`).

Per photon, both unit vectors are checked (length within the tolerance of 1), renormalised
and quantised to Jensen's polar codes (:mod:`.codec`: ``theta = acos(v_y)``, ``phi =
atan2(v_z, v_x)`` in [0, 2 pi), a byte each), and word 3 (``d | n << 16``) is written: the
numpy statement of the same steps (:func:`blockhash.index.records.codec.encode_directions`)
made ten passes over float64 working arrays.  The arithmetic is the numpy statement's, in
the same order, so the codes are the same bit for bit (``tests/index/records/test_polar_rows.py``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from blockhash.errors import InputError


def kernel_vectors(value, n: int, name: str) -> np.ndarray:
    """``value`` ((n, 3) reals, or None: an empty (0, 3) array, the default code) as the
    float32 or float64 array :func:`direction_words` reads."""
    if value is None:
        return np.zeros((0, 3))
    v = np.asarray(value)
    if v.dtype.kind not in "fiu" or v.shape != (n, 3):
        raise InputError(f"{name}: (n, 3) reals, one row per photon")
    return np.ascontiguousarray(v, dtype=v.dtype if v.dtype in (np.float32, np.float64)
                                else np.float64)


#: Photons per parallel task.
CHUNK = 16384


# error_model="numpy": a zero vector divides to NaN (and is reported), not raises
@numba.njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _code(x, y, z, tol, theta_step, phi_step):
    """(polar code, whether the length was within ``tol`` of 1) of one vector."""
    length = math.sqrt(x * x + y * y + z * z)
    ok = abs(length - 1.0) <= tol  # False for NaN
    x, y, z = x / length, y / length, z / length
    theta = math.acos(min(max(y, -1.0), 1.0))
    phi = math.atan2(z, x)
    if phi < 0.0:
        phi += 2.0 * math.pi
    t = min(math.floor(theta / theta_step), 255.0)
    p = np.int64(math.floor(phi / phi_step)) % 256
    return np.uint32(t) | (np.uint32(p) << np.uint32(8)), ok


@numba.njit(cache=True, nogil=True, parallel=True)
def direction_words(d, nrm, d_default, n_default, tol, theta_step, phi_step, out):
    """Writes ``d | n << 16`` into ``out`` ((n,) uint32) for directions ``d`` and normals
    ``nrm`` ((n, 3), float32 or float64; an array of shape (0, 3) for the default code
    ``d_default`` or ``n_default``).  Returns the first row whose direction and the first
    whose normal is not of unit length (-1 when none)."""
    n = out.shape[0]
    tasks = (n + CHUNK - 1) // CHUNK
    bad = np.full((tasks, 2), -1, dtype=np.int64)
    # The parallel loop only calls the task's function, compiled on its own: numba's parallel
    # pass then reads one call (a cold start's compilation), not the whole loop.
    for t in numba.prange(tasks):
        _words(d, nrm, d_default, n_default, tol, theta_step, phi_step, out, t * CHUNK,
               min(n, (t + 1) * CHUNK), bad[t])
    first_d = -1
    first_n = -1
    for t in range(tasks):
        if first_d < 0:
            first_d = bad[t, 0]
        if first_n < 0:
            first_n = bad[t, 1]
    return first_d, first_n


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _words(d, nrm, d_default, n_default, tol, theta_step, phi_step, out, first, end, bad):
    """:func:`direction_words` for rows ``first .. end - 1``; ``bad`` its first bad rows."""
    for i in range(first, end):
        cd = np.uint32(d_default)
        if d.shape[0]:
            cd, ok = _code(np.float64(d[i, 0]), np.float64(d[i, 1]), np.float64(d[i, 2]), tol,
                           theta_step, phi_step)
            if not ok and bad[0] < 0:
                bad[0] = i
        cn = np.uint32(n_default)
        if nrm.shape[0]:
            cn, ok = _code(np.float64(nrm[i, 0]), np.float64(nrm[i, 1]), np.float64(nrm[i, 2]),
                           tol, theta_step, phi_step)
            if not ok and bad[1] < 0:
                bad[1] = i
        out[i] = cd | (cn << np.uint32(16))
