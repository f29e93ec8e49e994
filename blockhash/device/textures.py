"""Textures on the device: :class:`DeviceTextures`, :meth:`blockhash.scene.texture.Texture.
value`'s lookup (``to_uv``, the wrap and the bilinear or nearest filter) in Dr.Jit, and
:class:`SurfaceTextures`, the host's :meth:`blockhash.scene.raycast.EmbreeGeometry.albedo`
(each face's texture coordinates interpolated at a hit) for the indirect photons' bounces
(:mod:`.indirect`); a spot light's projected texture is :mod:`.light_tables`'.  Every texture
is an array the kernels gather from."""

from __future__ import annotations

import numpy as np

from blockhash.device.arrays import floats, uints
from blockhash.scene.texture import FILTERS, WRAPS


class DeviceTextures:
    """``textures`` (:class:`~blockhash.scene.texture.Texture`) as device tables on ``device``:
    :meth:`value` looks one up as the host's ``Texture.value`` does."""

    def __init__(self, textures, device):
        self.mi, self.dr = mi, dr = device.modules()
        f32 = lambda a: floats(mi, a)  # noqa: E731
        sizes = np.array([t.image.shape[1::-1] for t in textures], dtype=np.uint32)  # (w, h)
        first = np.concatenate([[0], np.cumsum(sizes[:, 0] * sizes[:, 1])[:-1]]).astype(np.uint32)
        self.pixels = f32(np.concatenate([t.image.reshape(-1, 3) for t in textures]))
        self.first, self.width, self.height = (uints(mi, first), uints(mi, sizes[:, 0]),
                                               uints(mi, sizes[:, 1]))
        self.wrap = uints(mi, [WRAPS.index(t.wrap) for t in textures])
        self.nearest = uints(mi, [FILTERS.index(t.filter) for t in textures])
        self.to_uv = f32(np.stack([t.to_uv for t in textures]))  # (textures, 2, 3)
        dr.make_opaque(self.pixels, self.first, self.width, self.height, self.wrap,
                       self.nearest, self.to_uv)

    def value(self, t, uv, on):
        """Color3f: texture ``t`` (UInt32) at texture coordinates ``uv`` (Point2f, before its
        ``to_uv``) where ``on``."""
        mi, dr = self.mi, self.dr
        m = [dr.gather(mi.Float, self.to_uv, t * 6 + k, on) for k in range(6)]
        s = m[0] * uv.x + m[1] * uv.y + m[2]
        q = m[3] * uv.x + m[4] * uv.y + m[5]
        w, h = dr.gather(mi.UInt32, self.width, t, on), dr.gather(mi.UInt32, self.height, t, on)
        wf, hf = mi.Float(w), mi.Float(h)
        wrap = dr.gather(mi.UInt32, self.wrap, t, on)
        first = dr.gather(mi.UInt32, self.first, t, on)

        def fold(i, n):  # a pixel index (a whole Float) wrapped into [0, n)
            rep = i - n * dr.floor(i / n)
            clamp = dr.clip(i, 0.0, n - 1.0)
            p = i - 2.0 * n * dr.floor(i / (2.0 * n))
            mirror = dr.select(p < n, p, 2.0 * n - 1.0 - p)
            return mi.UInt32(dr.select(wrap == 0, rep, dr.select(wrap == 1, mirror, clamp)))

        def px(i, j):
            return dr.gather(mi.Color3f, self.pixels, first + fold(j, hf) * w + fold(i, wf), on)

        near = px(dr.floor(s * wf), dr.floor(q * hf))
        x, y = s * wf - 0.5, q * hf - 0.5
        i0, j0 = dr.floor(x), dr.floor(y)
        fx, fy = x - i0, y - j0
        top = px(i0, j0) * (1.0 - fx) + px(i0 + 1.0, j0) * fx
        bottom = px(i0, j0 + 1.0) * (1.0 - fx) + px(i0 + 1.0, j0 + 1.0) * fx
        lin = top * (1.0 - fy) + bottom * fy
        return dr.select(dr.gather(mi.UInt32, self.nearest, t, on) != 0, near, lin)


class SurfaceTextures:
    """The textured receivers of ``geometry`` (an :class:`~blockhash.scene.raycast.
    EmbreeGeometry`) on ``device``; build it only where the geometry has textures."""

    def __init__(self, geometry, device):
        self.mi, self.dr = mi, dr = device.modules()
        self.textures = DeviceTextures(geometry.textures, device)
        self.face_uv = mi.Float(np.ascontiguousarray(geometry.face_uv, np.float32).reshape(-1))
        self.texture_of = mi.Int32(np.asarray(geometry.texture_of, dtype=np.int32))
        dr.make_opaque(self.face_uv, self.texture_of)

    def albedo(self, obj, face, u, v, active):
        """(textured, Color3f): whether each hit's object has a texture, and its value at the
        hit on ``face`` with barycentrics ``u``, ``v``."""
        mi, dr = self.mi, self.dr
        t = dr.gather(mi.Int32, self.texture_of, obj, active)
        on = active & (t >= 0)
        corner = [dr.gather(mi.Point2f, self.face_uv, face * 3 + c, on) for c in range(3)]
        uv = (1.0 - u - v) * corner[0] + u * corner[1] + v * corner[2]
        return on, self.textures.value(mi.UInt32(dr.maximum(t, 0)), uv, on)
