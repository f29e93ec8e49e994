"""Photon emission toward the specular objects (importance sampling, still unbiased).

Each light shoots photons only into bounding cones around the mirrors it can
see; a photon's power is the light's power times the cone's share of the light's
emission solid angle, over the photons shot into it, so the caustic estimate
stays unbiased (see blockhash/photons/tracing.py).  Random numbers are counter-based:
photon i of a seed always gets the same ones, whatever the batch size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Bounding cones are widened by this much (in cosine) against rounding.
CONE_MARGIN = 1e-9
#: A sampled direction counts as inside a cone when its cosine to the axis is at
#: least cos(half-angle) - CONE_TEST_EPS: cone sampling rounds in the last bits.
CONE_TEST_EPS = 1e-12

#: Random numbers per photon: cone choice, two for the direction, one spare
#: (one Philox counter step gives four).
UNIFORMS_PER_PHOTON = 4


def cone_solid_angle(cos_half: float | np.ndarray):
    """Solid angle (sr) of a cone with the given cosine of its half-angle."""
    return 2.0 * np.pi * (1.0 - np.asarray(cos_half, dtype=np.float64))


def orthonormal_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (3,) completing unit ``axis`` to a right-handed frame (Duff et al. 2017)."""
    x, y, z = (float(c) for c in axis)
    sign = 1.0 if z >= 0.0 else -1.0
    a = -1.0 / (sign + z)
    b = x * y * a
    t1 = np.array([1.0 + sign * x * x * a, sign * b, -sign * x])
    t2 = np.array([b, sign + y * y * a, -y])
    return t1, t2


def sample_cones(axes, t1, t2, cos_half, u1, u2) -> np.ndarray:
    """(n, 3) directions uniform in solid angle inside per-photon cones.

    ``axes``, ``t1``, ``t2`` are (n, 3) orthonormal frames, ``cos_half`` (n,),
    ``u1``, ``u2`` (n,) uniforms in [0, 1).
    """
    cos_t = 1.0 - u1 * (1.0 - cos_half)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t * cos_t))
    phi = 2.0 * np.pi * u2
    d = (cos_t[:, None] * axes + (sin_t * np.cos(phi))[:, None] * t1
         + (sin_t * np.sin(phi))[:, None] * t2)
    return d / np.linalg.norm(d, axis=1, keepdims=True)

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

    @property
    def solid_angle(self) -> float:
        return float(cone_solid_angle(self.cos_half))


class Emitter:
    """Cone sampling toward the specular objects for every light."""

    def __init__(self, lights, specular_objects):
        self.positions, self.intensity, self.spot_axis, self.spot_cos = [], [], [], []
        cones: list[Cone] = []
        for li, light in enumerate(lights):
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
            self.intensity.append(power / emit_sa)
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
        self.cones = tuple(cones)
        self.n_lights = len(lights)
        # pmf over cones: power of the light falling into each cone
        brightness = np.array([float(np.mean(self.intensity[c.light])) * c.solid_angle
                               for c in cones])
        total = brightness.sum() if len(cones) else 0.0
        self.pmf = brightness / total if total > 0 else brightness
        self.cdf = np.cumsum(self.pmf)
        if len(cones):
            self.cdf[-1] = 1.0
        self.total_brightness = total

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

    def sample(self, u: np.ndarray):
        """Origins (n, 3), unit directions (n, 3), weights (n, 3) and light index (n,) from uniforms (n, 4)."""
        k = np.minimum(np.searchsorted(self.cdf, u[:, 0], side="right"), len(self.cones) - 1)
        axes = np.array([c.axis for c in self.cones])
        t1 = np.array([c.t1 for c in self.cones])
        t2 = np.array([c.t2 for c in self.cones])
        cos_h = np.array([c.cos_half for c in self.cones])
        dirs = sample_cones(axes[k], t1[k], t2[k], cos_h[k], u[:, 1], u[:, 2])
        light = np.array([c.light for c in self.cones], dtype=np.int64)[k]
        origins = np.array(self.positions)[light]
        # mixture density q(w) = sum over cones c containing w of pmf_c / solid_angle_c
        q = (self.pmf / np.array([c.solid_angle for c in self.cones]))[k]
        for j, c in enumerate(self.cones):
            other = (k != j) & (light == c.light)
            if other.any():
                inside = dirs[other] @ c.axis >= c.cos_half - CONE_TEST_EPS
                q[np.flatnonzero(other)[inside]] += self.pmf[j] / c.solid_angle
        weights = np.array(self.intensity)[light] / q[:, None]
        for li in range(self.n_lights):
            if self.spot_axis[li] is None:
                continue
            sel = light == li
            outside = dirs[sel] @ self.spot_axis[li] < self.spot_cos[li] - CONE_TEST_EPS
            weights[np.flatnonzero(sel)[outside]] = 0.0
        return origins, dirs, weights, light
