"""An environment light's map on the device: :class:`DeviceEnvironment`, the host's
:class:`blockhash.scene.environment_light.EnvironmentLight` (its bilinear radiance and its
sampling by cells, the same tables and rule) in Dr.Jit, for the caustic and indirect photons'
emission kernels.  Every number of the map is an array the kernels gather from, so another
map or another turn of it reuses the compiled kernels."""

from __future__ import annotations

from blockhash.device.arrays import floats, uints


class DeviceEnvironment:
    """``light`` (an EnvironmentLight) as device tables on ``device``."""

    def __init__(self, light, device):
        self.mi, self.dr = mi, dr = device.modules()
        h, w = light.image.shape[:2]
        f32 = lambda a: floats(mi, a)  # noqa: E731
        self.image = f32(light.image)
        self.row_cdf, self.col_cdf = f32(light.row_cdf), f32(light.column_cdf)
        self.pmf = f32(light.cell_pmf)
        self.band_cos, self.omega = f32(light.band_cos), f32(light.cell_solid_angle)
        self.rotation = f32(light.to_world)  # row by row
        self.size = uints(mi, [w, h])
        self.rows, self.columns = int(h - 1), int(w)
        dr.make_opaque(self.image, self.row_cdf, self.col_cdf, self.pmf, self.band_cos, self.omega, self.rotation,
                       self.size)

    def _frame(self, active):
        mi, dr = self.mi, self.dr
        return [dr.gather(mi.Vector3f, self.rotation, mi.UInt32(r), active) for r in range(3)]

    def _dims(self):
        mi, dr = self.mi, self.dr
        return dr.gather(mi.UInt32, self.size, mi.UInt32(0)), \
            dr.gather(mi.UInt32, self.size, mi.UInt32(1))

    def sample(self, u0, u1, u2, active):
        """(unit directions toward the map, density per steradian) of uniforms ``u0`` (the
        row of cells), ``u1`` (the cell in it, its remainder across the cell's column), ``u2``
        (across its band of cos theta), as
        :meth:`~blockhash.scene.environment_light.EnvironmentLight.sample`."""
        mi, dr = self.mi, self.dr
        w, _ = self._dims()
        rows, cols = self.row_cdf, self.col_cdf
        j = dr.binary_search(0, self.rows - 1, lambda k: dr.gather(mi.Float, rows, k, active) <= u0)
        j = dr.minimum(mi.UInt32(j), self.rows - 1)
        first = j * w
        i = dr.binary_search(0, self.columns - 1,
                             lambda k: dr.gather(mi.Float, cols, first + k, active) <= u1)
        i = dr.minimum(mi.UInt32(i), w - 1)
        lo = dr.select(i > 0, dr.gather(mi.Float, cols, first + i - 1, active & (i > 0)), 0.0)
        hi = dr.gather(mi.Float, cols, first + i, active)
        across = dr.clip((u1 - lo) / dr.maximum(hi - lo, 1e-30), 0.0, 0.99999994)
        cell = first + i
        phi = 2.0 * dr.pi * ((mi.Float(i) + across + 0.5) / mi.Float(w))
        c0 = dr.gather(mi.Float, self.band_cos, j, active)
        c1 = dr.gather(mi.Float, self.band_cos, j + 1, active)
        cos_t = dr.clip(c0 - u2 * (c0 - c1), -1.0, 1.0)
        sin_t = dr.safe_sqrt(1.0 - cos_t * cos_t)
        sin_p, cos_p = dr.sincos(phi)
        v = mi.Vector3f(sin_p * sin_t, cos_t, -cos_p * sin_t)
        r0, r1, r2 = self._frame(active)
        toward = dr.normalize(mi.Vector3f(dr.dot(r0, v), dr.dot(r1, v), dr.dot(r2, v)))
        pdf = dr.gather(mi.Float, self.pmf, cell, active) / dr.gather(mi.Float, self.omega, j,
                                                                      active)
        return toward, pdf

    def emitted(self, toward, active):
        """The map's radiance (Color3f) along directions ``toward`` (the host's
        :meth:`~blockhash.scene.environment_light.EnvironmentLight.emitted`)."""
        mi, dr = self.mi, self.dr
        w, h = self._dims()
        r0, r1, r2 = self._frame(active)
        v = r0 * toward.x + r1 * toward.y + r2 * toward.z  # R^T toward
        wf, hf = mi.Float(w), mi.Float(h)
        u = dr.atan2(v.x, -v.z) * (0.5 / dr.pi) - 0.5 / wf
        x = (u - dr.floor(u)) * wf
        y = dr.acos(dr.clip(v.y, -1.0, 1.0)) * (1.0 / dr.pi) * (hf - 1.0)
        i = dr.minimum(mi.UInt32(x), w - 1)
        j = dr.minimum(mi.UInt32(y), h - 2)
        fx, fy = x - mi.Float(i), y - mi.Float(j)
        i1 = dr.select(i + 1 >= w, 0, i + 1)

        def px(row, col):
            return dr.gather(mi.Color3f, self.image, row * w + col, active)

        top = px(j, i) * (1.0 - fx) + px(j, i1) * fx
        bottom = px(j + 1, i) * (1.0 - fx) + px(j + 1, i1) * fx
        return top * (1.0 - fy) + bottom * fy
