"""The scene's lights as Dr.Jit tables (:class:`LightTables`), read by the caustic and the
indirect photons' emission kernels (:mod:`.emission`, :mod:`.indirect`)."""

from __future__ import annotations

import math

import numpy as np

from blockhash.device.arrays import floats, uints


def float_table(mi, values, width=None):
    """A float32 device array of ``values`` (one 0 where there are none)."""
    a = np.asarray(values, dtype=np.float64)
    if width is not None:
        a = a.reshape(-1, width)
    return floats(mi, a if a.size else np.zeros(1))


def uint_table(mi, values):
    """A uint32 device array of ``values`` (one 0 where there are none)."""
    a = np.asarray(values, dtype=np.uint32).reshape(-1)
    return uints(mi, a if a.size else np.zeros(1))



class LightTables:
    """The scene's lights as device tables, by light index: positions, spot cones and their
    falloff, area lights' triangles (each light's own area cdf), directional lights' frames
    and the plane upstream of every object."""

    def __init__(self, lights, bounds, device):
        self.mi, self.dr = mi, dr = device.modules()
        from blockhash.photons.directions import orthonormal_basis
        from blockhash.scene.model import AreaLight, DirectionalLight, EnvironmentLight

        n = len(lights)
        spot = np.zeros(n, np.uint32)
        axis = np.zeros((n, 3))
        cos = np.full(n, -1.0)
        ramp = np.zeros(n, np.uint32)
        cone_rad = np.zeros(n)
        beam_rad = np.zeros(n)
        for li, light in enumerate(lights):
            cone_deg = getattr(light, "cone_deg", None)
            if cone_deg is not None:
                a = np.asarray(light.direction, dtype=np.float64)
                spot[li], axis[li], cos[li] = 1, a / np.linalg.norm(a), math.cos(math.radians(cone_deg))
                if not light.uniform:
                    ramp[li] = 1
                    cone_rad[li] = math.radians(light.cone_deg)
                    beam_rad[li] = math.radians(light.beam_deg)
        self.position = float_table(mi, [getattr(li, "position", (0.0, 0.0, 0.0)) for li in lights], 3)
        self.spot, self.spot_axis, self.spot_cos = uint_table(mi, spot), float_table(mi, axis), float_table(mi, cos)
        self.ramp, self.cone_rad, self.beam_rad = uint_table(mi, ramp), float_table(mi, cone_rad), float_table(mi, beam_rad)
        self.any_spot, self.any_ramp = bool(spot.any()), bool(ramp.any())
        # spots' projected textures: each one's index (-1: none), its frame's rows and tan(cone)
        textured = [li for li, light in enumerate(lights) if hasattr(light, "cone_deg")
                    and light.texture is not None]
        self.spot_textures = None
        if textured:
            from blockhash.device.textures import DeviceTextures

            self.spot_textures = DeviceTextures([lights[li].texture for li in textured], device)
            which = np.full(n, -1, np.int32)
            frames, tan = np.zeros((n, 3, 3)), np.ones(n)
            for k, li in enumerate(textured):
                which[li] = k
                frames[li] = lights[li].frame.T  # rows: the frame's x, y and axis
                tan[li] = math.tan(math.radians(lights[li].cone_deg))
            self.spot_texture, self.spot_frame = mi.Int32(which), float_table(mi, frames)
            self.spot_tan = float_table(mi, tan)
        # area lights: their triangles one after another, each light's area cdf over its own
        tri, normals, cdf, first, count, area, radiance = [], [], [], np.zeros(n), np.zeros(n), \
            np.zeros(n), np.zeros((n, 3))
        # directional lights: the direction, its frame and the plane upstream of every object
        sun_d, sun_t1, sun_t2, sun_s0, irradiance = (np.zeros((n, 3)), np.zeros((n, 3)),
                                                     np.zeros((n, 3)), np.zeros(n), np.zeros((n, 3)))
        lo, hi = np.asarray(bounds, dtype=np.float64)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        margin = 1e-3 * max(float(np.linalg.norm(hi - lo)), 1e-9)
        #: The box around every object (its corners) and the margin upstream of it: where an
        #: environment light's photons start, across each one's own direction.
        self.corners, self.margin = float_table(mi, corners), float_table(mi, [margin])
        self.environment, self.environment_light = None, None
        area_textures, area_uv, area_texture = [], [], np.full(n, -1, np.int32)
        for li, light in enumerate(lights):
            if isinstance(light, EnvironmentLight):
                from blockhash.device.environment import DeviceEnvironment

                self.environment, self.environment_light = DeviceEnvironment(light, device), li
            elif isinstance(light, AreaLight):
                first[li], count[li] = sum(len(t) for t in tri), len(light.face_areas)
                if light.texture is not None:
                    area_texture[li] = len(area_textures)
                    area_textures.append(light.texture)
                    area_uv.append(light.uv[np.asarray(light.mesh.faces)])
                else:
                    area_uv.append(np.zeros((len(light.face_areas), 3, 2)))
                tri.append(light.triangles)
                normals.append(light.face_normals)
                cdf.append(light.area_cdf)
                area[li], radiance[li] = light.area, light.radiance
            elif isinstance(light, DirectionalLight):
                d = np.asarray(light.direction, dtype=np.float64)
                d = d / np.linalg.norm(d)
                sun_d[li] = d
                sun_t1[li], sun_t2[li] = orthonormal_basis(d)
                sun_s0[li] = float((corners @ d).min()) - margin
                irradiance[li] = light.irradiance
        cat = lambda parts, w: np.concatenate(parts).reshape(-1, w) if parts else np.zeros((1, w))  # noqa: E731
        self.area_tri, self.area_normal = float_table(mi, cat(tri, 9)), float_table(mi, cat(normals, 3))
        self.area_cdf = float_table(mi, cat(cdf, 1))
        self.area_first, self.area_count = uint_table(mi, first), uint_table(mi, count)
        #: textured radiances: each area light's texture (-1: none), its triangles' corners'
        #: texture coordinates (in the area tables' order) and the textures
        self.area_textures = None
        if area_textures:
            from blockhash.device.textures import DeviceTextures

            self.area_textures = DeviceTextures(area_textures, device)
            self.area_texture = mi.Int32(area_texture)
            self.area_uv = float_table(mi, np.concatenate(area_uv))
        self.area, self.radiance = float_table(mi, area), float_table(mi, radiance)
        self.sun_d, self.sun_t1, self.sun_t2 = float_table(mi, sun_d), float_table(mi, sun_t1), float_table(mi, sun_t2)
        self.sun_s0, self.irradiance = float_table(mi, sun_s0), float_table(mi, irradiance)

    def spot_weight(self, light, d, w, on):
        """Nothing outside a spot's cone; its falloff between the beam and the cone; its
        projected texture (:meth:`blockhash.scene.lights.SpotLight.texture_factor`)."""
        mi, dr = self.mi, self.dr
        spot = on & (dr.gather(mi.UInt32, self.spot, light, on) != 0)
        cos = dr.dot(d, dr.gather(mi.Vector3f, self.spot_axis, light, spot))
        out = spot & (cos < dr.gather(mi.Float, self.spot_cos, light, spot) - 1e-6)
        w = dr.select(out, 0.0, w)
        if self.any_ramp:
            ramp = spot & (dr.gather(mi.UInt32, self.ramp, light, spot) != 0)
            c = dr.gather(mi.Float, self.cone_rad, light, ramp)
            b = dr.gather(mi.Float, self.beam_rad, light, ramp)
            theta = dr.acos(dr.clip(cos, -1.0, 1.0))
            f = dr.select(theta <= b, 1.0, dr.clip((c - theta) / dr.maximum(c - b, 1e-30), 0.0, 1.0))
            w = dr.select(ramp, w * dr.select(cos > dr.cos(c), f, 0.0), w)
        if self.spot_textures is not None:  # the texture projected across the cone
            t = dr.gather(mi.Int32, self.spot_texture, light, spot)
            on_t = spot & (t >= 0)
            x, y, z = (dr.dot(d, dr.gather(mi.Vector3f, self.spot_frame, light * 3 + r, on_t))
                       for r in range(3))
            k = 0.5 / (dr.select(z > 0.0, z, 1.0) * dr.gather(mi.Float, self.spot_tan, light, on_t))
            tint = self.spot_textures.value(mi.UInt32(dr.maximum(t, 0)),
                                            mi.Point2f(0.5 + x * k, 0.5 + y * k), on_t)
            w = dr.select(on_t, w * dr.select(z > 0.0, tint, 0.0), w)
        return w

    def upstream(self, D, on):
        """The offset along each direction ``D`` of a plane upstream of every object (the
        box's corners' least projection, less the margin)."""
        mi, dr = self.mi, self.dr
        s0 = dr.dot(dr.gather(mi.Vector3f, self.corners, mi.UInt32(0), on), D)
        for c in range(1, 8):
            s0 = dr.minimum(s0, dr.dot(dr.gather(mi.Vector3f, self.corners, mi.UInt32(c), on), D))
        return s0 - dr.gather(mi.Float, self.margin, mi.UInt32(0), on)

    def area_point(self, light, u_face, u1, u2, on):
        """(points, front normals, radiance there) uniform by area on the area lights
        ``light`` (the triangle of its area cdf that holds ``u_face``, barycentrics
        1 - sqrt(u1), sqrt(u1) u2), as :meth:`blockhash.scene.lights.AreaLight.points` and
        ``emitted_at``."""
        mi, dr = self.mi, self.dr
        first = dr.gather(mi.UInt32, self.area_first, light, on)
        count = dr.gather(mi.UInt32, self.area_count, light, on)
        last = dr.maximum(count, 1) - 1
        cdf = self.area_cdf
        f = dr.binary_search(0, 1 << 30, lambda i: (i < count) & (dr.gather(
            mi.Float, cdf, first + dr.minimum(i, last), on) <= u_face))
        f = first + dr.minimum(mi.UInt32(f), last)
        s = dr.sqrt(u1)
        b0, b2 = 1.0 - s, s * u2
        p = [dr.gather(mi.Point3f, self.area_tri, f * 3 + c, on) for c in range(3)]
        radiance = dr.gather(mi.Color3f, self.radiance, light, on)
        if self.area_textures is not None:  # a textured radiance at the point
            t = dr.gather(mi.Int32, self.area_texture, light, on)
            on_t = on & (t >= 0)
            c = [dr.gather(mi.Point2f, self.area_uv, f * 3 + k, on_t) for k in range(3)]
            uv = b0 * c[0] + (1.0 - b0 - b2) * c[1] + b2 * c[2]
            radiance = dr.select(on_t, self.area_textures.value(mi.UInt32(dr.maximum(t, 0)), uv,
                                                                 on_t), radiance)
        return b0 * p[0] + (1.0 - b0 - b2) * p[1] + b2 * p[2], \
            dr.gather(mi.Vector3f, self.area_normal, f, on), radiance
