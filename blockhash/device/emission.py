"""The photons' emission as a Dr.Jit kernel: :class:`blockhash.photons.emission.Emitter`'s
tables (its pmf over the point and spot lights' cones and the area and directional lights'
targets, the cones' projection maps, the mixture densities) sampled on the device.

The same rules as the host's (:mod:`blockhash.photons.emission`,
:mod:`blockhash.photons.light_targets`), in float32: a source by the pmf; a cone's direction
in a live cell of its projection map (kept in its own live cell, else the first live one of
its hashed sequence), the weight the light's intensity over the mixture density of the
light's cones that hold it, zero outside a spot's cone and its falloff toward the edge; an
area light's point uniform by area,
a direction in the cone toward the target's bounding sphere, the weight ``L cos A / q``; a
directional light's point in the target's disc upstream of the scene, the weight ``E / q``;
an environment light's direction by its map's cells (:mod:`.environment`), then the
directional light's discs across it, the weight ``L / (p q)``.  The lights' own tables are
:mod:`.light_tables`'.
Every number of the scene is an array the kernels gather from (none a literal of the code),
so a light that moves between frames reuses the compiled kernel.

Cones are sampled and tested by ``1 - cos`` (``omc``), the cone's own measure: a cone of a
small, distant mirror keeps its directions' precision in float32.
"""

from __future__ import annotations

import math

import numpy as np

from blockhash.device.light_tables import LightTables, float_table, uint_table
from blockhash.photons.directions import NEAR_REFERENCE, REFERENCE, SECOND_REFERENCE
from blockhash.photons.emission import MAP_CELLS, STABLE_TRIES, tried_cell
from blockhash.photons.light_targets import INSIDE

#: A direction is inside a cone when ``1 - cos`` to its axis is at most the cone's times
#: (1 + REL_EPS) plus ABS_EPS (float32 rounding; the host tests in float64 by 1e-12).
REL_EPS, ABS_EPS = 1e-4, 1e-9
#: Uniforms a photon's emission draws: the source, two for the direction, the map's cell, and
#: an area light's triangle and point.
EMISSION_UNIFORMS = 7


def _omc(cos_half: float) -> float:
    return 2.0 if cos_half <= -1.0 else float(1.0 - cos_half)


def cone_frame(mi, dr, axis):
    """(t1, t2) completing unit ``axis`` to a right-handed frame, continuous in the axis: the
    host's :func:`blockhash.photons.directions.frames` on the device (Mitsuba's ``Frame3f``
    turns half a circle where the axis's z changes sign, which would move a moving area
    light's photons from one frame to the next)."""
    ref, second = (mi.Vector3f(*map(float, v)) for v in (REFERENCE, SECOND_REFERENCE))
    t1 = dr.cross(ref, axis)
    near = dr.norm(t1) < NEAR_REFERENCE
    t1 = dr.normalize(dr.select(near, dr.cross(second, axis), t1))
    return t1, dr.cross(axis, t1)


def in_cone(dr, axis, t1, t2, omc, u1, u2):
    """The direction of uniforms (u1, u2), uniform in solid angle in the cone (``axis``, frame
    ``t1`` ``t2``, ``omc`` = 1 - cos of the half angle)."""
    x = u1 * omc  # 1 - cos theta
    cos_t = 1.0 - x
    sin_t = dr.safe_sqrt(x * (2.0 - x))
    sin_p, cos_p = dr.sincos(2.0 * dr.pi * u2)
    return dr.normalize(cos_t * axis + (sin_t * cos_p) * t1 + (sin_t * sin_p) * t2)


class DeviceEmitter:
    """An :class:`~blockhash.photons.emission.Emitter` (``emitter``) of the scene's ``lights``
    as device tables (module docstring); :meth:`sample` emits."""

    def __init__(self, emitter, lights, bounds, device):
        self.mi, self.dr = mi, dr = device.modules()
        self.n_sources = emitter.sources
        self.n_cones = len(emitter.cones)
        self.cdf = float_table(mi, emitter.cdf)
        self.intensity = float_table(mi, emitter.intensity, 3)
        pmf = np.asarray(emitter.pmf, dtype=np.float64)
        self.lights = LightTables(lights, bounds, device)
        self._cones(emitter, pmf[:self.n_cones])
        self._targets(emitter, pmf[self.n_cones:])

    # ------------------------------------------------------------------ tables
    def _cones(self, emitter, pmf):
        mi, g = self.mi, MAP_CELLS
        cones = emitter.cones
        self.cone_groups = [(j, [i for i, c in enumerate(cones) if c.light == cj.light and i != j])
                            for j, cj in enumerate(cones)]
        self.cone_groups = [(j, o) for j, o in self.cone_groups if o]
        if not cones:
            return
        self.c_axis = float_table(mi, [c.axis for c in cones])
        self.c_t1 = float_table(mi, [c.t1 for c in cones])
        self.c_t2 = float_table(mi, [c.t2 for c in cones])
        self.c_omc = float_table(mi, [_omc(c.cos_half) for c in cones])
        self.c_light = uint_table(mi, [c.light for c in cones])
        self.c_density = float_table(mi, [p / (c.solid_angle * c.live_fraction) for c, p in zip(cones, pmf)])
        cells, first, count, live = [], [], [], []
        for c in cones:
            first.append(sum(len(x) for x in cells))
            cells.append(c.live_cells)
            count.append(len(c.live_cells))
            live.append(c.live.reshape(-1) if c.live is not None else np.ones(g * g, bool))
        self.c_cells = uint_table(mi, np.concatenate(cells))
        self.c_first, self.c_count = uint_table(mi, first), uint_table(mi, count)
        self.c_live = uint_table(mi, np.concatenate(live))

    def _targets(self, emitter, pmf):
        mi = self.mi
        targets = emitter.targets
        self.n_targets = len(targets)
        self.kinds = {t.kind for t in targets}
        self.target_groups = [[j for j, t in enumerate(targets) if t.light == li]
                              for li in sorted({t.light for t in targets})]
        self.t_light = uint_table(mi, [t.light for t in targets])
        self.t_center = float_table(mi, [t.center for t in targets])
        self.t_radius = float_table(mi, [t.radius for t in targets])
        self.t_pmf = float_table(mi, pmf)
        self.t_area = uint_table(mi, [t.kind == "area" for t in targets])
        self.t_environment = uint_table(mi, [t.kind == "environment" for t in targets])

    # ------------------------------------------------------------------ sampling
    def sample(self, rng):
        """(origins, unit directions, weights, light index) of the photons of ``rng``'s lanes
        (their streams: the first :data:`EMISSION_UNIFORMS` uniforms of each)."""
        mi, dr = self.mi, self.dr
        u = [rng.next_float32() for _ in range(EMISSION_UNIFORMS)]
        n = dr.width(u[0])
        cdf = self.cdf
        k = dr.binary_search(0, self.n_sources - 1,
                             lambda i: dr.gather(mi.Float, cdf, i) <= u[0])
        k = dr.minimum(mi.UInt32(k), self.n_sources - 1)
        o, d, w = dr.zeros(mi.Point3f, n), mi.Vector3f(0, 0, 1) + dr.zeros(mi.Vector3f, n), \
            dr.zeros(mi.Color3f, n)
        light = dr.zeros(mi.UInt32, n)
        if self.n_cones:
            on = k < self.n_cones
            oc, dc, wc, lc = self._cone_photons(dr.select(on, k, 0), on, u)
            o, d, w, light = oc, dc, dr.select(on, wc, w), dr.select(on, lc, light)
        if self.n_targets:
            on = k >= self.n_cones
            t = dr.select(on, k - self.n_cones, 0)
            ot, dt, wt, lt = self._target_photons(t, on, u)
            o, d, w, light = (dr.select(on, ot, o), dr.select(on, dt, d), dr.select(on, wt, w),
                              dr.select(on, lt, light))
        return o, d, w, light

    def _cone_photons(self, k, on, u):
        mi, dr, g = self.mi, self.dr, MAP_CELLS
        gv = lambda table: dr.gather(mi.Vector3f, table, k, on)  # noqa: E731
        gf = lambda table: dr.gather(mi.Float, table, k, on)  # noqa: E731
        axis, t1, t2, omc = gv(self.c_axis), gv(self.c_t1), gv(self.c_t2), gf(self.c_omc)
        count = dr.gather(mi.UInt32, self.c_count, k, on)
        u1, u2 = u[1], u[2]
        move = on & (count > 0)
        # a photon in a live cell of its own stays there
        ci = dr.minimum(mi.UInt32(u1 * g), g - 1)
        cj = dr.minimum(mi.UInt32(u2 * g), g - 1)
        own = dr.gather(mi.UInt32, self.c_live, k * (g * g) + ci * g + cj, move) != 0
        u1 = dr.select(move & ~own, u1 * g - mi.Float(ci), u1)
        u2 = dr.select(move & ~own, u2 * g - mi.Float(cj), u2)
        move &= ~own
        found, cell = self._tried_cells(k, move, u[3])
        u1 = dr.select(found, (mi.Float(cell // g) + u1) / g, u1)
        u2 = dr.select(found, (mi.Float(cell % g) + u2) / g, u2)
        move &= ~found
        slot = dr.minimum(mi.UInt32(u[3] * mi.Float(count)), dr.maximum(count, 1) - 1)
        cell = dr.gather(mi.UInt32, self.c_cells, dr.gather(mi.UInt32, self.c_first, k, on) + slot,
                         move)
        u1 = dr.select(move, (mi.Float(cell // g) + u1) / g, u1)
        u2 = dr.select(move, (mi.Float(cell % g) + u2) / g, u2)
        d = in_cone(dr, axis, t1, t2, omc, u1, u2)
        light = dr.gather(mi.UInt32, self.c_light, k, on)
        q = gf(self.c_density)
        for j, others in self.cone_groups:  # the other cones of k's light that hold d
            mine = on & (k != j) & (light == dr.gather(mi.UInt32, self.c_light, mi.UInt32(j)))
            q += dr.select(mine & self._in_cone_j(j, d, mine), dr.gather(mi.Float, self.c_density,
                                                                         mi.UInt32(j)), 0.0)
        lt = self.lights
        w = dr.gather(mi.Color3f, self.intensity, light, on) / q
        if lt.any_spot:
            w = lt.spot_weight(light, d, w, on)
        o = dr.gather(mi.Point3f, lt.position, light, on)
        return o, d, w, light

    def _tried_cells(self, k, active, u3):
        """(found, cell): the first live cell of cone ``k``'s map among the
        :data:`~blockhash.photons.emission.STABLE_TRIES` of each ``active`` photon's hashed
        sequence (:meth:`blockhash.photons.emission.Emitter._stable_cells`, the host's rule;
        :func:`~blockhash.photons.emission.tried_cell` the same hash), seeded by ``u3``."""
        mi, dr, g = self.mi, self.dr, MAP_CELLS
        seed = mi.UInt32(u3 * float(2 ** 24)) << 8  # a float32 uniform's 24 bits, on top
        base = k * (g * g)

        def body(t, found, cell):
            x = tried_cell(seed, t, u32=int)
            hit = ~found & (dr.gather(mi.UInt32, self.c_live, base + x, active & ~found) != 0)
            return t + 1, found | hit, dr.select(hit, x, cell)

        zero = dr.zeros(mi.UInt32, dr.width(u3))
        _, found, cell = dr.while_loop(
            (zero, dr.zeros(mi.Bool, dr.width(u3)), zero),
            lambda t, found, cell: active & ~found & (t < STABLE_TRIES), body,
            labels=("t", "found", "cell"), label="stable_cells")
        return found & active, cell

    def _in_cone_j(self, j, d, active):
        """``d`` lies in cone ``j`` and, where it has a projection map, in a live cell."""
        mi, dr, g = self.mi, self.dr, MAP_CELLS
        jj = mi.UInt32(j)
        axis = dr.gather(mi.Vector3f, self.c_axis, jj)
        omc = dr.gather(mi.Float, self.c_omc, jj)
        x = 0.5 * dr.squared_norm(d - axis)
        inside = active & (x <= omc * (1.0 + REL_EPS) + ABS_EPS)
        phi = dr.atan2(dr.dot(d, dr.gather(mi.Vector3f, self.c_t2, jj)),
                       dr.dot(d, dr.gather(mi.Vector3f, self.c_t1, jj)))
        phi = dr.select(phi < 0.0, phi + 2.0 * dr.pi, phi)
        ci = dr.minimum(mi.UInt32(dr.maximum(x / omc, 0.0) * g), g - 1)
        cj = dr.minimum(mi.UInt32(phi * (g / (2.0 * math.pi))), g - 1)
        live = dr.gather(mi.UInt32, self.c_live, jj * (g * g) + ci * g + cj, inside)
        return inside & (live != 0)

    def _target_photons(self, t, on, u):
        mi, dr = self.mi, self.dr
        n = dr.width(t)
        light = dr.gather(mi.UInt32, self.t_light, t, on)
        o, d, w = dr.zeros(mi.Point3f, n), mi.Vector3f(0, 0, 1) + dr.zeros(mi.Vector3f, n), \
            dr.zeros(mi.Color3f, n)
        area = on & (dr.gather(mi.UInt32, self.t_area, t, on) != 0)
        if "area" in self.kinds:
            oa, da, wa = self._area(t, light, area, u)
            o, d, w = dr.select(area, oa, o), dr.select(area, da, d), dr.select(area, wa, w)
        env = on & (dr.gather(mi.UInt32, self.t_environment, t, on) != 0)
        if "environment" in self.kinds:
            oe, de, we = self._environment(t, light, env, u)
            o, d, w = dr.select(env, oe, o), dr.select(env, de, d), dr.select(env, we, w)
        if "directional" in self.kinds:
            sun = on & ~area & ~env
            os_, ds, ws = self._directional(t, light, sun, u)
            o, d, w = dr.select(sun, os_, o), dr.select(sun, ds, d), dr.select(sun, ws, w)
        return o, d, w, light

    def _target_cone(self, j, y, active):
        """(axis, 1 - cos half) from points ``y`` toward target ``j``'s bounding sphere (the
        whole sphere of directions from inside it)."""
        mi, dr = self.mi, self.dr
        c = dr.gather(mi.Point3f, self.t_center, j, active)
        r = dr.gather(mi.Float, self.t_radius, j, active)
        to = c - y
        dist = dr.norm(to)
        inside = dist <= r * INSIDE
        axis = dr.select(inside, mi.Vector3f(0, 0, 1), to / dr.maximum(dist, 1e-30))
        sin2 = dr.square(r / dr.maximum(dist, 1e-30))
        omc = sin2 / (1.0 + dr.safe_sqrt(1.0 - sin2))  # 1 - sqrt(1 - sin2), without cancelling
        return axis, dr.select(inside, 2.0, dr.minimum(omc * (1.0 + REL_EPS) + ABS_EPS, 2.0))

    def _area(self, t, light, on, u):
        mi, dr = self.mi, self.dr
        lt = self.lights
        y, ny, radiance = lt.area_point(light, u[4], u[5], u[6], on)
        axis, omc = self._target_cone(t, y, on)
        d = in_cone(dr, axis, *cone_frame(mi, dr, axis), omc, u[1], u[2])
        q = dr.zeros(mi.Float, dr.width(t))
        for group in self.target_groups:  # the mixture over the light's targets
            for j in group:
                jj = mi.UInt32(j)
                mine = on & (light == dr.gather(mi.UInt32, self.t_light, jj))
                a, m = self._target_cone(jj + dr.zeros(mi.UInt32, dr.width(t)), y, mine)
                inside = mine & ((t == j) | (0.5 * dr.squared_norm(d - a) <= m))
                q += dr.select(inside, dr.gather(mi.Float, self.t_pmf, jj) / (2.0 * dr.pi * m), 0.0)
        cos_y = dr.maximum(dr.dot(d, ny), 0.0)
        w = radiance * (
            cos_y * dr.gather(mi.Float, lt.area, light, on) / dr.maximum(q, 1e-30))
        return y, d, w

    def _directional(self, t, light, on, u):
        mi, dr = self.mi, self.dr
        lt = self.lights
        gv = lambda table: dr.gather(mi.Vector3f, table, light, on)  # noqa: E731
        D, t1, t2 = gv(lt.sun_d), gv(lt.sun_t1), gv(lt.sun_t2)
        o, q = self._disc(t, light, on, u, D, t1, t2, dr.gather(mi.Float, lt.sun_s0, light, on))
        return o, D, dr.gather(mi.Color3f, lt.irradiance, light, on) / dr.maximum(q, 1e-30)

    def _environment(self, t, light, on, u):
        """An environment light's photons: a direction by its map (:mod:`.environment`), then
        the directional light's discs across it; the weight ``L / (p q)``."""
        mi, dr = self.mi, self.dr
        env = self.lights.environment
        toward, p = env.sample(u[4], u[5], u[6], on)
        D = -toward
        t1, t2 = cone_frame(mi, dr, D)
        o, q = self._disc(t, light, on, u, D, t1, t2, self.lights.upstream(D, on))
        return o, D, env.emitted(toward, on) / dr.maximum(p * q, 1e-30)

    def _disc(self, t, light, on, u, D, t1, t2, s0):
        """(origins, mixture density q per square metre) of photons along ``D`` (frame ``t1``
        ``t2``) from a point in target ``t``'s disc across it, on the plane ``s0`` upstream
        (:meth:`blockhash.photons.light_targets.SurfaceSampler._disc`)."""
        mi, dr = self.mi, self.dr
        c = dr.gather(mi.Vector3f, self.t_center, t, on)
        r = dr.gather(mi.Float, self.t_radius, t, on)
        rho = r * dr.sqrt(u[1])
        sin_p, cos_p = dr.sincos(2.0 * dr.pi * u[2])
        a = dr.dot(c, t1) + rho * cos_p
        b = dr.dot(c, t2) + rho * sin_p
        q = dr.zeros(mi.Float, dr.width(t))
        for group in self.target_groups:
            for j in group:
                jj = mi.UInt32(j)
                mine = on & (light == dr.gather(mi.UInt32, self.t_light, jj))
                cj = dr.gather(mi.Vector3f, self.t_center, jj)
                rj = dr.gather(mi.Float, self.t_radius, jj)
                da, db = a - dr.dot(cj, t1), b - dr.dot(cj, t2)
                inside = mine & ((t == j) | (da * da + db * db <= rj * rj * (1.0 + REL_EPS)))
                q += dr.select(inside, dr.gather(mi.Float, self.t_pmf, jj) / (dr.pi * rj * rj), 0.0)
        return mi.Point3f(a * t1 + b * t2 + s0 * D), q
