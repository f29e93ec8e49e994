"""Unit vectors as octahedral words: the map's two coordinates in two snorm16 (Cigolle et al.
2014), the cover gather's record directions and normals.  glsl/bh_octahedral.glsl decodes
them with no trigonometry, where Figure 4's polar codes need four sines and cosines; this
module is its CPU reference."""

from __future__ import annotations

import functools

import numpy as np

from blockhash.index.records.codec import decode_directions


def octahedral_encode(v: np.ndarray) -> np.ndarray:
    """(n, 3) unit vectors -> (n,) uint32: the octahedral map's two coordinates as snorm16,
    x in the low half (GLSL ``unpackSnorm2x16``)."""
    v = np.asarray(v, dtype=np.float64)
    p = v[:, :2] / np.maximum(np.abs(v).sum(axis=1, keepdims=True), 1e-300)
    sign = np.where(p >= 0, 1.0, -1.0)
    p = np.where(v[:, 2:3] < 0, (1.0 - np.abs(p[:, ::-1])) * sign, p)
    q = np.round(np.clip(p, -1.0, 1.0) * 32767.0).astype(np.int16).view(np.uint16).astype(np.uint32)
    return q[:, 0] | (q[:, 1] << np.uint32(16))


def octahedral_decode(words) -> np.ndarray:
    """(n,) uint32 -> (n, 3) float32 unit vectors, in float32 as glsl/bh_octahedral.glsl's
    bh_octahedral evaluates them (up to its inversesqrt)."""
    w = np.asarray(words, dtype=np.uint32)
    f = np.stack([(w & np.uint32(0xFFFF)).astype(np.uint16).view(np.int16),
                  (w >> np.uint32(16)).astype(np.uint16).view(np.int16)], axis=1)
    f = np.clip(f.astype(np.float32) / np.float32(32767.0), np.float32(-1), np.float32(1))
    z = np.float32(1.0) - np.abs(f[:, 0]) - np.abs(f[:, 1])
    t = np.maximum(-z, np.float32(0.0))
    x = f[:, 0] + np.where(f[:, 0] >= 0, -t, t)
    y = f[:, 1] + np.where(f[:, 1] >= 0, -t, t)
    v = np.stack([x, y, z], axis=1).astype(np.float32)
    return (v / np.sqrt((v * v).sum(axis=1, keepdims=True))).astype(np.float32)


@functools.cache
def octahedral_tables() -> tuple[np.ndarray, np.ndarray]:
    """(65536,) uint32 each: the octahedral word of every polar code's decoded direction,
    negated (toward where the photon came from) and as it is (the normal).  A record's
    16-bit polar codes index them, the same words as encoding each record's direction."""
    v = decode_directions(np.arange(1 << 16, dtype=np.uint16)).astype(np.float64)
    return octahedral_encode(-v), octahedral_encode(v)


__all__ = ["octahedral_encode", "octahedral_decode", "octahedral_tables"]
