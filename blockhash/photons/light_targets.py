"""Photons from area and directional lights toward the specular objects.

A point or spot light's photons leave one point (:mod:`.emission`'s cones).  An area light's
and a directional light's leave a surface, so each photon draws its origin first and its
direction second, toward one *target*, a specular object's bounding sphere (centre ``c``,
radius ``r``):

* **Area light** (:class:`blockhash.scene.model.AreaLight`, radiance ``L`` from the front of
  each face): a point ``y`` uniform by area on the light (density ``1 / A``), then a target
  ``j`` of that light with probability ``pmf_j`` (the emitter's global pmf), then a direction
  uniform inside the cone from ``y`` that holds target ``j``'s sphere (half angle
  ``asin(r / |c - y|)``; the whole sphere of directions where ``y`` lies inside it).  The
  density of the direction given ``y`` is the mixture ``q(w | y) = sum_j pmf_j [w in cone_j(y)]
  / Omega_j(y)`` over the light's targets, so a photon's weight is its exact
  ``L cos(theta_y) A / q(w | y)``: zero behind the face, and unbiased wherever a specular
  object can be met whatever the aiming.
* **Directional light** (sunlight, irradiance ``E`` across its direction ``D``): the plane
  perpendicular to ``D`` upstream of the whole scene holds one disc per target (the sphere's
  shadow on it, radius ``r``); a photon picks target ``j`` by ``pmf_j``, a point uniform in its
  disc and travels along ``D``; its weight is ``E / q(x)``, ``q(x) = sum_j pmf_j [x in disc_j]
  / (pi r_j^2)``.  No photon is shot where no specular object is.
* **Environment light** (:class:`blockhash.scene.environment_light.EnvironmentLight`): a
  direction ``w`` toward the map drawn by its own sampling (density ``p(w)`` per steradian),
  then the directional light's discs across ``-w``; the weight is ``L(w) / (p(w) q(x | w))``.
  A target's brightness is ``pi r^2`` times the radiance integrated over the sphere.

``pmf_j`` is proportional to an estimate of the flux the light sends into target ``j``'s cone
or disc (:func:`area_brightness`); a poor estimate costs noise, never bias.  A target that the
light cannot reach at all (the sphere wholly behind every face of the light) gets none.

The area light's point on the light draws three more uniforms per photon from a counter range
of its own (:func:`surface_uniforms`), so the point and spot lights' photons keep their
streams: a scene of point and spot lights traces the same photons as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockhash.photons.directions import frames, orthonormal_basis, sample_cones

#: Philox counters of the area lights' extra uniforms start this far past the photon's own
#: (photon i of the streams reads counter SURFACE_COUNTER + i): a range no pass reaches.
SURFACE_COUNTER = 1 << 120
#: A cone from inside (or on) a target's bounding sphere is the whole sphere of directions.
INSIDE = 1.0 + 1e-9
#: Cones are widened by this much (in cosine) against rounding.
CONE_MARGIN = 1e-9


@dataclass(frozen=True)
class Target:
    """One light's photons toward one specular object: ``light`` (index into the scene's
    lights), ``kind`` ('area' or 'directional'), the object's bounding sphere (``center`` (3,),
    ``radius``) and the estimated flux the light sends at it (``brightness``, W)."""

    light: int
    object_name: str
    kind: str
    center: np.ndarray
    radius: float
    brightness: float


def bounding_sphere(vertices: np.ndarray) -> tuple[np.ndarray, float]:
    """(centre (3,), radius): the box's centre and the largest distance to a vertex."""
    center = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
    return center, float(np.max(np.linalg.norm(vertices - center, axis=1))) * (1.0 + 1e-9)


def area_brightness(light, center: np.ndarray, radius: float) -> float:
    """An estimate of the watts ``light`` (an AreaLight) sends into the cones that hold the
    sphere (``center``, ``radius``): per face, ``L area cos Omega`` at its centroid, the cosine
    taken to the sphere's nearest reach in front of the face (so a sphere that pokes in front
    of any face gets a positive share, and only one wholly behind every face gets 0)."""
    tri = light.triangles
    centroid = tri.mean(axis=1)
    to = center - centroid
    dist = np.linalg.norm(to, axis=1)
    reach = (np.einsum("ij,ij->i", to, light.face_normals) + radius) / np.maximum(dist, 1e-300)
    cos = np.clip(reach, 0.0, 1.0)
    sin2 = np.clip((radius / np.maximum(dist, 1e-300)) ** 2, 0.0, 1.0)
    omega = np.where(dist <= radius * INSIDE, 2.0 * np.pi, 2.0 * np.pi * (1.0 - np.sqrt(1.0 - sin2)))
    return float(np.mean(light.radiance) * np.sum(light.face_areas * cos * omega))


def light_targets(lights, specular_objects, scene_bounds: np.ndarray) -> list[Target]:
    """The targets of the scene's area and directional lights (point and spot lights are
    :mod:`.emission`'s cones), those with positive brightness only."""
    from blockhash.scene.model import AreaLight, DirectionalLight, EnvironmentLight

    spheres = [(str(o.name), *bounding_sphere(np.asarray(o.mesh.vertices, dtype=np.float64)))
               for o in specular_objects if len(o.mesh.faces)]
    out = []
    for li, light in enumerate(lights):
        for name, center, radius in spheres:
            if isinstance(light, AreaLight):
                b = area_brightness(light, center, radius)
                kind = "area"
            elif isinstance(light, DirectionalLight):
                b = float(np.mean(light.irradiance)) * np.pi * radius * radius
                kind = "directional"
            elif isinstance(light, EnvironmentLight):
                b = float(np.mean(light.integral)) * np.pi * radius * radius
                kind = "environment"
            else:
                continue
            if b > 0.0:
                out.append(Target(li, name, kind, center, radius, b))
    return out


def surface_uniforms(seed: int, start: int, count: int) -> np.ndarray:
    """(count, 4) uniforms of photons ``start ..`` for a point on an area light (triangle,
    two barycentric; one spare), from Philox counter ``SURFACE_COUNTER + start`` under
    ``seed`` (module docstring)."""
    bitgen = np.random.Philox(key=seed, counter=SURFACE_COUNTER + start)
    return np.random.Generator(bitgen).random((count, 4))


class SurfaceSampler:
    """Origins, directions and weights of the photons that chose a target
    (:class:`Target`) of an area or directional light (module docstring).  ``targets`` are
    the emitter's, ``pmf`` their share of the emitter's global pmf (the same order);
    ``lights`` the scene's lights; ``scene_bounds`` (2, 3) the box around every object."""

    def __init__(self, targets, pmf, lights, scene_bounds):
        self.targets = tuple(targets)
        self.pmf = np.asarray(pmf, dtype=np.float64)
        self.lights = lights
        self.centers = np.array([t.center for t in self.targets]).reshape(-1, 3)
        self.radii = np.array([t.radius for t in self.targets])
        self.light = np.array([t.light for t in self.targets], dtype=np.int64)
        lo, hi = np.asarray(scene_bounds, dtype=np.float64)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        self._corners = corners
        self._margin = 1e-3 * max(float(np.linalg.norm(hi - lo)), 1e-9)

    def sample(self, j: np.ndarray, u: np.ndarray, extra: np.ndarray):
        """(origins, dirs, weights) (n, 3) each for photons whose target is ``j`` (n,) (an
        index into ``targets``), from their uniforms ``u`` (n, 4) and ``extra`` (n, 4)."""
        n = len(j)
        origins, dirs, weights = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        for li in np.unique(self.light[j]):
            rows = np.flatnonzero(self.light[j] == li)
            light = self.lights[li]
            if hasattr(light, "face_areas"):
                o, d, w = self._area(li, light, j[rows], u[rows], extra[rows])
            elif hasattr(light, "image"):
                o, d, w = self._environment(li, light, j[rows], u[rows], extra[rows])
            else:
                o, d, w = self._directional(li, light, j[rows], u[rows])
            origins[rows], dirs[rows], weights[rows] = o, d, w
        return origins, dirs, weights

    def _area(self, li, light, j, u, extra):
        n = len(j)
        y, ny = light.points(extra[:, 0], extra[:, 1], extra[:, 2])
        mine = np.flatnonzero(self.light == li)  # this light's targets
        cos_h = np.empty((n, len(mine)))
        axes = np.empty((n, len(mine), 3))
        for col, t in enumerate(mine):
            to = self.centers[t] - y
            dist = np.linalg.norm(to, axis=1)
            inside = dist <= self.radii[t] * INSIDE
            axes[:, col] = np.where(inside[:, None], np.array([0.0, 0.0, 1.0]),
                                    to / np.maximum(dist, 1e-300)[:, None])
            sin2 = np.where(inside, 1.0, (self.radii[t] / np.maximum(dist, 1e-300)) ** 2)
            cos_h[:, col] = np.where(inside, -1.0, np.sqrt(np.maximum(1.0 - sin2, 0.0)) - CONE_MARGIN)
        col_of = np.searchsorted(mine, j)
        axis = axes[np.arange(n), col_of]
        t1, t2 = frames(axis)
        d = sample_cones(axis, t1, t2, cos_h[np.arange(n), col_of], u[:, 1], u[:, 2])
        q = np.zeros(n)
        for col, t in enumerate(mine):
            inside = np.einsum("ij,ij->i", d, axes[:, col]) >= cos_h[:, col] - 1e-12
            q += np.where(inside, self.pmf[t] / (2.0 * np.pi * (1.0 - cos_h[:, col])), 0.0)
        cos_y = np.maximum(np.einsum("ij,ij->i", d, ny), 0.0)
        radiance = light.emitted_at(extra[:, 0], extra[:, 1], extra[:, 2])
        w = radiance * (cos_y * light.area / q)[:, None]
        return y, d, w

    def _directional(self, li, light, j, u):
        D = np.asarray(light.direction, dtype=np.float64)
        t1, t2 = orthonormal_basis(D)
        origins, q = self._disc(li, j, u, np.broadcast_to(D, (len(j), 3)),
                                np.broadcast_to(t1, (len(j), 3)), np.broadcast_to(t2, (len(j), 3)))
        dirs = np.broadcast_to(D, (len(j), 3)).copy()
        return origins, dirs, light.irradiance[None, :] / q[:, None]

    def _environment(self, li, light, j, u, extra):
        toward, p = light.sample(extra[:, 0], extra[:, 1], extra[:, 2])
        D = -toward
        t1, t2 = frames(D)
        origins, q = self._disc(li, j, u, D, t1, t2)
        w = light.emitted(toward) / (p * q)[:, None]
        return origins, D, w

    def _disc(self, li, j, u, D, t1, t2):
        """(origins (n, 3), mixture density q (n,) per square metre) of photons travelling
        along ``D`` (n, 3) (frames ``t1``, ``t2``) from a point in target ``j``'s disc across
        it, upstream of every object (module docstring)."""
        s0 = (self._corners @ D.T).min(axis=0) - self._margin
        c = self.centers[j]
        rho = self.radii[j] * np.sqrt(u[:, 1])
        phi = 2.0 * np.pi * u[:, 2]
        a = np.einsum("ij,ij->i", c, t1) + rho * np.cos(phi)
        b = np.einsum("ij,ij->i", c, t2) + rho * np.sin(phi)
        q = np.zeros(len(j))
        for t in np.flatnonzero(self.light == li):
            da = a - t1 @ self.centers[t]
            db = b - t2 @ self.centers[t]
            inside = da * da + db * db <= self.radii[t] ** 2 * (1.0 + 1e-12)
            q += np.where(inside, self.pmf[t] / (np.pi * self.radii[t] ** 2), 0.0)
        return a[:, None] * t1 + b[:, None] * t2 + s0[:, None] * D, q
