"""Photon emission toward the specular objects (importance sampling, still unbiased).

Each light shoots photons only into bounding cones around the mirrors it can
see; a photon's power is the light's power times the cone's share of the light's
emission solid angle, over the photons shot into it, so the caustic estimate
stays unbiased (see blockhash/photons/tracing.py).  Random numbers are counter-based:
photon i of a seed always gets the same ones, whatever the batch size.

Given the scene's geometry, each cone also gets a projection map (Jensen 1996, "Global
illumination using photon maps", section 3.1): its directions split into
``MAP_CELLS`` x ``MAP_CELLS`` cells of equal solid angle (cos theta by phi), ``MAP_PILOTS``
x ``MAP_PILOTS`` pilot rays a cell, and a cell live when a pilot ray of it or of a
neighbouring cell first meets a specular object.  Photons are shot into live cells only,
their density raised by the cone's live fraction, so the photons that would miss the mirrors
or first meet a diffuse surface (the light's direct light, which the renderer's shadow rays
compute) are not traced at all.  A photon whose own cell is live keeps its direction; one in
a dead cell moves into the first live cell of its own hashed sequence of cells, keeping its
place in the cell (:meth:`Emitter._stable_cells`): when the light moves and the map changes,
only the photons of the cells that changed move (common random numbers for frames).  A
direction that reaches a mirror through a dead cell would be lost: the dilation by a cell
keeps every mirror edge a pilot ray saw; a mirror feature
thinner than a cell and missed by every pilot ray of three cells is the limit
(:func:`projection_map`).  The light tracer (:mod:`blockhash.reference.lighttrace`) samples
the plain cones, so it checks the map independently.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from blockhash.photons.directions import cone_solid_angle, orthonormal_basis, sample_cones  # noqa: F401

#: Bounding cones are widened by this much (in cosine) against rounding.
CONE_MARGIN = 1e-9
#: A sampled direction counts as inside a cone when its cosine to the axis is at
#: least cos(half-angle) - CONE_TEST_EPS: cone sampling rounds in the last bits.
CONE_TEST_EPS = 1e-12

#: Random numbers per photon: cone choice, two for the direction, one for the projection
#: map's cell (one Philox counter step gives four).
UNIFORMS_PER_PHOTON = 4
#: Cells per side of a cone's projection map (cos theta by phi, each of equal solid angle).
MAP_CELLS = 128
#: Pilot rays per cell side of a projection map (stratified, at the sub-cells' centres).
MAP_PILOTS = 2
#: Cells a photon in a dead cell tries, in its own hashed sequence
#: (:func:`tried_cell`), before the rank among the live cells places it.
STABLE_TRIES = 64
#: The sequence's step and the mixer's multipliers (Wellons' lowbias32 integer hash).
GOLDEN, MIX1, MIX2 = 0x9E3779B9, 0x7FEB352D, 0x846CA68B


def photon_uniforms(seed: int, start: int, count: int) -> np.ndarray:
    """(count, 4) uniforms in [0, 1) of photons ``start .. start+count-1``.

    Row ``i`` comes from Philox counter ``start + i`` under key ``seed`` alone,
    so any photon's numbers are the same however the photons are batched.
    """
    bitgen = np.random.Philox(key=seed, counter=start)
    return np.random.Generator(bitgen).random((count, UNIFORMS_PER_PHOTON))


def bounding_cone(apex: np.ndarray, vertices: np.ndarray, center: np.ndarray):
    """(axis (3,), cos_half) of a cone from ``apex`` containing every vertex.

    The axis points at ``center``; the half-angle is the largest angle to a vertex.
    A cone of 90 degrees or more is not convex, so it becomes the whole sphere
    (``cos_half = -1``), as does an apex inside the geometry's bounding sphere.
    """
    axis = center - apex
    dist = np.linalg.norm(axis)
    w = vertices - apex
    wn = np.linalg.norm(w, axis=1)
    radius = float(np.max(np.linalg.norm(vertices - center, axis=1)))
    if dist <= radius or wn.min() <= 0.0:
        return np.array([0.0, 0.0, 1.0]), -1.0
    axis = axis / dist
    cos_half = float(np.min((w @ axis) / wn)) - CONE_MARGIN
    if cos_half <= 0.0:
        return axis, -1.0
    return axis, cos_half


# --------------------------------------------------------------------------- scene pieces

@dataclass(frozen=True)
class Cone:
    light: int
    object_name: str
    axis: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    cos_half: float
    sampled: str  # 'object' or 'spot'
    #: (MAP_CELLS, MAP_CELLS) bool live cells of its projection map (None: every cell)
    live: np.ndarray | None = None

    @property
    def solid_angle(self) -> float:
        return float(cone_solid_angle(self.cos_half))

    @property
    def live_fraction(self) -> float:
        return 1.0 if self.live is None else float(self.live.mean())

    @property
    def live_cells(self) -> np.ndarray:
        return np.flatnonzero(self.live) if self.live is not None else np.zeros(0, np.int64)

    def cells_of(self, dirs: np.ndarray) -> np.ndarray:
        """(n,) flat map cell of each unit direction (inside the cone)."""
        g = MAP_CELLS
        u1 = (1.0 - dirs @ self.axis) / max(1.0 - self.cos_half, 1e-300)
        phi = np.arctan2(dirs @ self.t2, dirs @ self.t1) % (2.0 * np.pi)
        i = np.clip((u1 * g).astype(np.int64), 0, g - 1)
        j = np.clip((phi / (2.0 * np.pi) * g).astype(np.int64), 0, g - 1)
        return i * g + j


def projection_map(cone: Cone, origin: np.ndarray, geometry) -> np.ndarray:
    """(MAP_CELLS, MAP_CELLS) bool: the cells of ``cone`` (from the light at ``origin``)
    whose pilot rays, or a neighbouring cell's, first meet a specular object of
    ``geometry`` (:class:`blockhash.scene.raycast.EmbreeGeometry`)."""
    from blockhash.scene.raycast import RAY_OFFSET

    g, s = MAP_CELLS, MAP_PILOTS
    sub = (np.arange(g * s) + 0.5) / (g * s)
    u1, u2 = (a.reshape(-1) for a in np.meshgrid(sub, sub, indexing="ij"))
    n = len(u1)
    d = sample_cones(np.tile(cone.axis, (n, 1)), np.tile(cone.t1, (n, 1)),
                     np.tile(cone.t2, (n, 1)), np.full(n, cone.cos_half), u1, u2)
    o = origin + d * (RAY_OFFSET * geometry.scale)
    hit, face, _, _ = geometry.intersect(o, d)
    first = np.zeros(n, dtype=bool)
    first[np.flatnonzero(hit)] = geometry.casts[geometry.face_object[face]]
    live = first.reshape(g, s, g, s).any(axis=(1, 3))
    grown = live.copy()  # one cell around: theta clamped at the cone's axis and rim, phi wraps
    for di in (-1, 0, 1):
        rows = np.roll(live, di, axis=0)
        if di == 1:
            rows[0] = False
        elif di == -1:
            rows[-1] = False
        for dj in (-1, 0, 1):
            grown |= np.roll(rows, dj, axis=1)
    return grown


class Emitter:
    """Cone sampling toward the specular objects for every light; with ``geometry``, into
    each cone's projection map's live cells (module docstring)."""

    def __init__(self, lights, specular_objects, geometry=None, bounds=None):
        from blockhash.photons.light_targets import SurfaceSampler, light_targets

        self.positions, self.intensity, self.spot_axis, self.spot_cos = [], [], [], []
        cones: list[Cone] = []
        for li, light in enumerate(lights):
            if not hasattr(light, "position"):  # area and directional: light_targets
                self.positions.append(np.zeros(3))
                self.intensity.append(np.zeros(3))
                self.spot_axis.append(None)
                self.spot_cos.append(-1.0)
                continue
            pos = np.asarray(light.position, dtype=np.float64)
            power = np.asarray(light.power, dtype=np.float64)
            cone_deg = getattr(light, "cone_deg", None)
            if cone_deg is None:
                emit_sa, s_axis, s_cos = 4.0 * np.pi, None, -1.0
            else:
                s_axis = np.asarray(light.direction, dtype=np.float64)
                s_axis = s_axis / np.linalg.norm(s_axis)
                s_cos = float(np.cos(np.radians(float(cone_deg))))
                emit_sa = float(cone_solid_angle(s_cos))
            self.positions.append(pos)
            # a spot's peak (its falloff, SpotLight.falloff, weighs each photon: _sample_cones)
            self.intensity.append(light.peak_intensity if cone_deg is not None else power / emit_sa)
            self.spot_axis.append(s_axis)
            self.spot_cos.append(s_cos)
            for obj in specular_objects:
                if len(obj.mesh.faces) == 0:
                    continue
                verts = np.asarray(obj.mesh.vertices, dtype=np.float64)
                center = 0.5 * (verts.min(axis=0) + verts.max(axis=0))
                axis, cos_a = bounding_cone(pos, verts, center)
                chosen = self._clip_to_spot(axis, cos_a, s_axis, s_cos)
                if chosen is None:
                    continue
                axis, cos_h, which = chosen
                t1, t2 = orthonormal_basis(axis)
                cones.append(Cone(li, str(obj.name), axis, t1, t2, cos_h, which))
        if geometry is not None:
            mapped = [replace(c, live=projection_map(c, self.positions[c.light], geometry))
                      for c in cones]
            # Cones none of whose directions reach a mirror first go; when none is left, the
            # plain cones stay, and the tracer finds (and reports) what their photons meet.
            mapped = [c for c in mapped if c.live.any()]
            cones = mapped or cones
        self.cones = tuple(cones)
        self.lights = tuple(lights)
        self.n_lights = len(lights)
        if bounds is None:
            boxes = np.array([o.mesh.bounds for o in specular_objects]).reshape(-1, 2, 3)
            bounds = np.stack([boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)])
        self.targets = tuple(light_targets(lights, specular_objects, bounds))
        # pmf over cones, then the area and directional lights' targets: power of the light
        # falling into each
        brightness = np.array([float(np.mean(self.intensity[c.light])) * c.solid_angle
                               * c.live_fraction for c in cones]
                              + [t.brightness for t in self.targets])
        total = brightness.sum() if len(brightness) else 0.0
        self.pmf = brightness / total if total > 0 else brightness
        self.cdf = np.cumsum(self.pmf)
        if len(self.cdf):
            self.cdf[-1] = 1.0
        self.total_brightness = total
        self.surfaces = (SurfaceSampler(self.targets, self.pmf[len(cones):], lights, bounds)
                         if self.targets else None)

    @property
    def sources(self) -> int:
        """Cones and targets: what a photon chooses between (0: no light reaches a specular
        object)."""
        return len(self.cones) + len(self.targets)

    def uniforms(self, seed: int, start: int, count: int):
        """The uniforms :meth:`sample` takes for photons ``start .. start + count - 1``."""
        u = photon_uniforms(seed, start, count)
        if self.surfaces is None:
            return u
        from blockhash.photons.light_targets import surface_uniforms

        return u, surface_uniforms(seed, start, count)

    @staticmethod
    def _clip_to_spot(axis, cos_a, s_axis, s_cos):
        """The cone to sample for an object cone and a spot cone, or None when they are disjoint."""
        if s_axis is None:
            return axis, cos_a, "object"
        alpha = np.arccos(np.clip(cos_a, -1.0, 1.0))
        beta = np.arccos(np.clip(s_cos, -1.0, 1.0))
        gamma = np.arccos(np.clip(float(axis @ s_axis), -1.0, 1.0))
        if gamma >= alpha + beta:
            return None
        if gamma + alpha <= beta:
            return axis, cos_a, "object"
        if gamma + beta <= alpha:
            return s_axis, s_cos, "spot"
        # partial overlap: sample the smaller cone, photons outside the spot carry nothing
        return (axis, cos_a, "object") if cos_a >= s_cos else (s_axis, s_cos, "spot")

    def sample(self, u):
        """Origins (n, 3), unit directions (n, 3), weights (n, 3) and light index (n,) from
        :meth:`uniforms` (n, 4), or with area or directional lights (their pair)."""
        if self.surfaces is None:
            return self._sample_cones(u)
        u, extra = u
        k = np.minimum(np.searchsorted(self.cdf, u[:, 0], side="right"), self.sources - 1)
        n = len(u)
        origins, dirs, weights = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        light = np.zeros(n, dtype=np.int64)
        on_cone = k < len(self.cones)
        if on_cone.any():
            rows = np.flatnonzero(on_cone)
            origins[rows], dirs[rows], weights[rows], light[rows] = self._sample_cones(u[rows])
        rows = np.flatnonzero(~on_cone)
        if len(rows):
            j = k[rows] - len(self.cones)
            origins[rows], dirs[rows], weights[rows] = self.surfaces.sample(j, u[rows], extra[rows])
            light[rows] = np.array([t.light for t in self.targets], dtype=np.int64)[j]
        return origins, dirs, weights, light

    def _sample_cones(self, u: np.ndarray):
        """:meth:`sample` for photons whose uniforms choose a point or spot light's cone."""
        k = np.minimum(np.searchsorted(self.cdf, u[:, 0], side="right"), len(self.cones) - 1)
        axes = np.array([c.axis for c in self.cones])
        t1 = np.array([c.t1 for c in self.cones])
        t2 = np.array([c.t2 for c in self.cones])
        cos_h = np.array([c.cos_half for c in self.cones])
        u1, u2 = self._cells(k, u)
        if len(self.cones) == 1:  # one cone: its frame broadcast, not gathered per photon
            dirs = sample_cones(axes, t1, t2, cos_h, u1, u2)
        else:
            dirs = sample_cones(axes[k], t1[k], t2[k], cos_h[k], u1, u2)
        light = np.array([c.light for c in self.cones], dtype=np.int64)[k]
        origins = np.array(self.positions)[light]
        # mixture density q(w) = sum over cones c whose live cells hold w of
        # pmf_c / (solid_angle_c live_fraction_c)
        density = self.pmf[:len(self.cones)] / np.array([c.solid_angle * c.live_fraction
                                                         for c in self.cones])
        q = density[k]
        for j, c in enumerate(self.cones):
            other = (k != j) & (light == c.light)
            if other.any():
                rows = np.flatnonzero(other)
                inside = dirs[rows] @ c.axis >= c.cos_half - CONE_TEST_EPS
                rows = rows[inside]
                if c.live is not None:
                    rows = rows[c.live.reshape(-1)[c.cells_of(dirs[rows])]]
                q[rows] += density[j]
        weights = np.array(self.intensity)[light] / q[:, None]
        for li in range(self.n_lights):
            if self.spot_axis[li] is None:
                continue
            rows = np.flatnonzero(light == li)
            cos = dirs[rows] @ self.spot_axis[li]
            weights[rows[cos < self.spot_cos[li] - CONE_TEST_EPS]] = 0.0
            if not self.lights[li].uniform:  # the beam's falloff toward the cone's edge
                weights[rows] *= self.lights[li].falloff(cos)[:, None]
            if self.lights[li].texture is not None:  # a texture projected across the cone
                weights[rows] *= self.lights[li].texture_factor(dirs[rows])
        return origins, dirs, weights, light

    def _cells(self, k: np.ndarray, u: np.ndarray):
        """The direction uniforms (u1, u2) of each photon, moved into a live cell of its cone's
        projection map (unchanged for a cone without a map): kept in its own cell when that is
        live, else the first live cell of its hashed sequence (:meth:`_stable_cells`), else
        the live cell of rank ``u[:, 3]``."""
        u1, u2 = u[:, 1].copy(), u[:, 2].copy()
        for j, c in enumerate(self.cones):
            if c.live is None:
                continue
            rows = np.flatnonzero(k == j)
            rows = self._stable_cells(c, rows, u, u1, u2)
            cells = c.live_cells
            pick = cells[np.minimum((u[rows, 3] * len(cells)).astype(np.int64), len(cells) - 1)]
            i, jj = np.divmod(pick, MAP_CELLS)
            u1[rows] = (i + u1[rows]) / MAP_CELLS
            u2[rows] = (jj + u2[rows]) / MAP_CELLS
        return u1, u2

    @staticmethod
    def _stable_cells(c: Cone, rows, u, u1, u2):
        """Cone ``c``'s photons (``rows``) placed stably: a photon whose own cell is live
        stays there; one in a dead cell tries the cells of its own hashed sequence
        (:func:`tried_cell`, seeded by ``u[:, 3]``) and moves into the first live one, keeping
        its place in the cell.  Each try is uniform over the map, so the first live one is
        uniform over the live cells; and a photon moves between frames (a light that moves, a
        map that changes) only when its cell dies or a cell before it in its sequence comes
        alive, not when any other cell changes (common random numbers: frames differ by the
        light's change, not by reshuffled photons; the rank rule alone moves every photon after
        a changed cell).
        Returns the rows still to place (none live among :data:`STABLE_TRIES` tries: the rank
        rule places them, uniform over the live cells as well)."""
        g = MAP_CELLS
        ci = np.minimum((u1[rows] * g).astype(np.int64), g - 1)
        cj = np.minimum((u2[rows] * g).astype(np.int64), g - 1)
        dead = ~c.live[ci, cj]
        rows = rows[dead]
        u1[rows] = u1[rows] * g - ci[dead]
        u2[rows] = u2[rows] * g - cj[dead]
        seed = (u[rows, 3] * 2.0 ** 32).astype(np.uint32)
        live = c.live.reshape(-1)
        for t in range(STABLE_TRIES):
            if not len(rows):
                break
            cell = tried_cell(seed, t)
            ok = live[cell]
            i, jj = np.divmod(cell[ok].astype(np.int64), g)
            u1[rows[ok]] = (i + u1[rows[ok]]) / g
            u2[rows[ok]] = (jj + u2[rows[ok]]) / g
            rows, seed = rows[~ok], seed[~ok]
        return rows


def tried_cell(seed, t, u32=np.uint32):
    """Flat map cell of try ``t`` (an int, or a UInt32 on the device) of the photons of uint32
    ``seed``: Wellons' lowbias32 hash of ``seed ^ (t * GOLDEN)``, modulo the map's cells (a
    power of two, so uniform).  One code for numpy arrays and Dr.Jit's (:mod:`blockhash.device.
    emission`, ``u32=int``): ``u32`` makes the constants of ``seed``'s type."""
    x = seed ^ (t * u32(GOLDEN)) if u32 is int else seed ^ u32((t * GOLDEN) & 0xFFFFFFFF)
    x = (x ^ (x >> u32(16))) * u32(MIX1)
    x = (x ^ (x >> u32(15))) * u32(MIX2)
    return (x ^ (x >> u32(16))) & u32(MAP_CELLS * MAP_CELLS - 1)
