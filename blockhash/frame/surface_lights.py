"""Direct light from area and directional lights, and an area light's own radiance seen.

* **Area light** (:class:`blockhash.scene.model.AreaLight`): each shading point takes one
  point ``y`` on the light per pass, uniform by area, and one shadow ray to it; its radiance
  is ``L f_r(wi, wo) cos(theta_x) cos(theta_y) A / d^2`` (zero where ``y``'s face turns away).
  The point on the light comes from a 2-D Kronecker sequence over the passes
  (:data:`LIGHT_STEP`) under a random shift of each point's own (Cranley-Patterson, as the camera samples of :func:`blockhash.frame.
  subpixel.pass_offsets`): the first coordinate picks the triangle by area and, rescaled,
  is the first barycentric one, so any run of n passes covers the light about as evenly as
  n stratified samples, and soft shadows converge with passes.
* **Directional light**: a shadow ray against its direction, out of the scene; radiance
  ``E f_r(wi, wo) cos(theta_x)``.
* **Environment light** (:class:`blockhash.scene.environment_light.EnvironmentLight`): one
  direction per shading point and pass drawn by the map's own sampling from the same
  per-point sequence as an area light's point (the cell and its column from the first
  coordinate, the band from the second), a shadow ray out of the scene; radiance
  ``L(w) f_r(wi, wo) cos(theta_x) / p(w)``.
* **Emission seen**: a shading point on an area light's object whose viewer is on the front
  of the face it lies on adds the light's radiance ``L`` (times the path weight, as every
  term of the direct layer), so the light is seen directly and in mirrors and glass; a camera
  ray that left the scene (:attr:`blockhash.frame.shading_points.ShadingPoints.escaped`) sees the
  environment's radiance along it.
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.scene.coat import through
from blockhash.scene.raycast import RAY_OFFSET

#: Seed of the per-point shifts of the light samples (one fixed stream: an image is the same
#: in every run).
LIGHT_SAMPLE_SEED = 0x11A5
#: The step of the light samples' sequence over passes: dimensions 3 and 4 of Roberts' R4
#: Kronecker sequence (1 / phi_4^3, 1 / phi_4^4, phi_4 the real root of x^5 = x + 1).  The
#: camera samples take R2's steps (:data:`blockhash.frame.subpixel.R2_STEP`); the light taking
#: the same would tie each pass's point on the light to its point in the pixel (the 4-D
#: points on one 2-D lattice), and the soft shadows would converge more slowly.
LIGHT_STEP = (0.6287067210378086, 0.5385972572236101)


def light_uniforms(samples: int, owner: np.ndarray, pass_index: int,
                   light_index: int) -> np.ndarray:
    """(len(owner), 2) uniforms of pass ``pass_index``'s light sample at points of camera
    samples ``owner`` (flat indices into ``samples`` camera samples; module docstring): the
    shift is the camera sample's, so it follows the pixel from pass to pass however the
    points are laid out (glass's two branches share their sample's), one shift per light."""
    rng = np.random.default_rng([LIGHT_SAMPLE_SEED, int(light_index)])
    shift = rng.random((samples, 2))[owner]
    return np.mod(shift + pass_index * np.asarray(LIGHT_STEP), 1.0)


def points_on_light(light, u: np.ndarray):
    """(points (n, 3), front normals (n, 3), radiance there (n, 3)) on ``light`` (an
    AreaLight) from uniforms ``u`` (n, 2): the triangle by area from ``u[:, 0]``, its remainder
    in that triangle's stretch of the CDF and ``u[:, 1]`` the uniform barycentrics
    (:meth:`blockhash.scene.lights.AreaLight.points`)."""
    cdf = light.area_cdf
    f = np.minimum(np.searchsorted(cdf, u[:, 0], side="right"), len(cdf) - 1)
    lo = np.where(f > 0, cdf[np.maximum(f - 1, 0)], 0.0)
    width = np.maximum(cdf[f] - lo, 1e-300)
    args = (u[:, 0], np.clip((u[:, 0] - lo) / width, 0.0, 1.0), u[:, 1])
    return (*light.points(*args), light.emitted_at(*args))


def light_points_from(light, u: np.ndarray, x: np.ndarray):
    """:func:`points_on_light` seen from points ``x`` (n, 3): (points, front normals, radiance,
    unit directions from ``x`` toward the points, their squared distances, the cosines at the
    light, positive where the light faces ``x``)."""
    y, ny, radiance = points_on_light(light, u)
    to = y - x
    d2 = np.einsum("ij,ij->i", to, to)
    toward = to / np.maximum(np.sqrt(d2), 1e-300)[:, None]
    return y, ny, radiance, toward, d2, -np.einsum("ij,ij->i", toward, ny)


def area_light(out, light, live, p, n, wo, mat, kd, ks, e, coat, rays, pass_index: int,
               light_index: int, owner: np.ndarray, samples: int) -> None:
    """Adds to ``out`` (flat (m, 3)) the direct light of ``light`` (an AreaLight) at the
    points ``live`` (module docstring), ``owner`` (m,) their camera samples, of ``samples``."""
    if not len(live):
        return
    u = light_uniforms(samples, owner[live], pass_index, light_index)
    x = p[live].astype(np.float64)
    nx = n[live].astype(np.float64)
    y, ny, radiance, wi, d2, cos_y = light_points_from(light, u, x)
    cos_x = np.einsum("ij,ij->i", wi, nx)
    ok = np.flatnonzero((cos_y > 0.0) & (cos_x > 0.0) & (d2 > 0.0))
    if not len(ok):
        return
    offset = RAY_OFFSET * rays.scale
    origins = x[ok] + nx[ok] * offset
    end = y[ok] + ny[ok] * offset
    seg = end - origins
    length = np.linalg.norm(seg, axis=1)
    lit = ~rays.occluded(origins, seg / length[:, None], length * (1 - 1e-6))
    ok = ok[lit]
    li = radiance[ok] * (cos_y[ok] * light.area / d2[ok])[:, None]
    _shade(out, live[ok], wi[ok], n, wo, mat, kd, ks, e, coat, li)


def directional_light(out, light, live, p, n, wo, mat, kd, ks, e, coat, rays) -> None:
    """Adds to ``out`` the direct light of ``light`` (a DirectionalLight) at ``live``."""
    if not len(live):
        return
    toward = -np.asarray(light.direction, dtype=np.float64)
    nx = n[live].astype(np.float64)
    ok = np.flatnonzero(nx @ toward > 0.0)
    if not len(ok):
        return
    dirs = np.broadcast_to(toward, (len(ok), 3)).copy()
    lit = escapes(rays, p[live[ok]], nx[ok], dirs)
    ok = ok[lit]
    li = np.broadcast_to(light.irradiance, (len(ok), 3))
    _shade(out, live[ok], dirs[lit], n, wo, mat, kd, ks, e, coat, np.ascontiguousarray(li))


def environment_light(out, light, live, p, n, wo, mat, kd, ks, e, coat, rays, pass_index: int,
                      light_index: int, owner: np.ndarray, samples: int) -> None:
    """Adds to ``out`` the direct light of ``light`` (an EnvironmentLight) at ``live``: one
    direction per point by the map's sampling (module docstring)."""
    if not len(live):
        return
    u = light_uniforms(samples, owner[live], pass_index, light_index)
    toward, pdf = light.sample(u[:, 0], None, u[:, 1])
    nx = n[live].astype(np.float64)
    ok = np.flatnonzero((np.einsum("ij,ij->i", toward, nx) > 0.0) & (pdf > 0.0))
    if not len(ok):
        return
    lit = escapes(rays, p[live[ok]], nx[ok], toward[ok])
    ok = ok[lit]
    li = light.emitted(toward[ok]) / pdf[ok, None]
    _shade(out, live[ok], toward[ok], n, wo, mat, kd, ks, e, coat, li)


def environment_seen(out, lights, points) -> None:
    """Adds to ``out`` (flat (m, 3)) an environment light's radiance along each camera ray
    that left the scene (:attr:`blockhash.frame.shading_points.ShadingPoints.escaped`)."""
    if points.escaped is None:
        return
    gone = np.flatnonzero(points.escaped.reshape(-1))
    toward = -points.view.reshape(-1, 3)[gone].astype(np.float64)
    toward /= np.maximum(np.linalg.norm(toward, axis=1, keepdims=True), 1e-30)
    pdf = None if points.rough_pdf is None else points.rough_pdf.reshape(-1)[gone]
    out[gone] += environments_along(lights, toward, pdf)


def environments_along(lights, toward, rough_pdf=None) -> np.ndarray:
    """(m, 3) the environment lights' radiance along rays leaving the scene along ``toward``
    (m, 3), each weighted against the light's own directions where a rough vertex sent the
    ray (``rough_pdf`` (m,) its density, inf where none did; None: none did;
    :func:`sampled_weight`)."""
    out = np.zeros((len(toward), 3))
    for light in lights:
        if hasattr(light, "image"):
            seen = light.emitted(toward)
            if rough_pdf is not None:
                seen = seen * sampled_weight(rough_pdf, light.pdf(toward))[:, None]
            out += seen
    return out


def sampled_weight(p_sampled, p_light):
    """The power heuristic's weight ``p_b^2 / (p_b^2 + p_l^2)`` of light met by a rough
    vertex's sampled ray of density ``p_sampled`` (inf: the ray left no rough vertex, weight
    1) where the light's own sampling has density ``p_light`` (the same measure)."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratio = np.asarray(p_light, np.float64) / np.asarray(p_sampled, np.float64)
    return np.where(np.isfinite(ratio), 1.0 / (1.0 + ratio * ratio), 0.0)


def light_weight(q, cos_y, area):
    """:func:`sampled_weight` of an area light of ``area`` met by a rough vertex's sampled
    ray: ``q`` the ray's :func:`blockhash.frame.rough_direct.sampling_pdf` over its length
    squared (inf: the ray left no rough vertex, weight 1), ``cos_y`` the light's face to the
    ray (per unit area, against the light's 1 / area)."""
    return sampled_weight(np.asarray(q, np.float64) * np.abs(cos_y), 1.0 / area)


def escapes(rays, points, normals, dirs) -> np.ndarray:
    """(m,) bool: nothing of the scene lies along ``dirs`` from ``points`` (lifted off their
    surface along ``normals``): the ray leaves the scene."""
    offset = RAY_OFFSET * rays.scale
    origins = points.astype(np.float64) + normals * offset
    far = np.full(len(origins), 4.0 * rays.scale + float(np.abs(origins).max()) * 2.0 + 1.0)
    return ~rays.occluded(origins, np.ascontiguousarray(dirs), far)


def emission_seen(out, lights, objects, p, wo, mat, rays, rough_pdf=None) -> None:
    """Adds to ``out`` each area light's radiance at the points on its object whose viewer
    (``wo``) is on the front of the face (a ray cast back at the point tells the side); at
    points reached by a rough vertex's sampled ray, times the ray's weight against the light's
    own points (``rough_pdf`` (m,), :func:`light_weight`'s q; None: none was)."""
    names = {o.name: i for i, o in enumerate(objects)}
    for light in lights:
        if not hasattr(light, "radiance"):
            continue
        on = np.flatnonzero(mat == names[light.object])
        if not len(on):
            continue
        v = wo[on].astype(np.float64)
        lift = 8.0 * RAY_OFFSET * rays.scale
        hit, _, _, obj, geo, outer, face, bary = rays.first_hit(
            p[on].astype(np.float64) + v * lift, -v, sides=True, faces=True)
        front = hit & outer & (obj == names[light.object])
        # the light's own face: the geometry numbers the faces object by object
        first = int(np.searchsorted(rays.geometry.face_object, names[light.object]))
        f = face[front] - first
        seen = light.emitted_on(f, bary[front, 0], bary[front, 1])
        if rough_pdf is not None:
            cos_y = np.sum(geo[front] * v[front], axis=1)
            seen = seen * light_weight(rough_pdf[on[front]], cos_y, light.area)[:, None]
        out[on[front]] += seen


@numba.njit(cache=True, nogil=True, parallel=True)
def _shade(out, idx, wi, n, wo, mat, kd, ks, e, coat, li):
    """Adds to ``out[idx]`` f_r(wi, wo) cos(theta) li: the modified Phong f_r of
    :func:`blockhash.scene.materials.phong_brdf` (times the coat's transmittance toward
    ``wi``, ``coat`` the ray caster's per-object table: :func:`blockhash.scene.coat.through`)
    and ``li`` (m, 3) the
    light arriving along ``wi`` (radiance times its solid angle, or irradiance)."""
    for j in numba.prange(len(idx)):
        i = idx[j]
        w0, w1, w2 = wi[j, 0], wi[j, 1], wi[j, 2]
        cos = (w0 * n[i, 0] + w1 * n[i, 1]) + w2 * n[i, 2]
        if cos <= 0.0:
            continue
        m = mat[i]
        c_alpha = ((2.0 * cos * n[i, 0] - w0) * wo[i, 0] + (2.0 * cos * n[i, 1] - w1) * wo[i, 1]) \
            + (2.0 * cos * n[i, 2] - w2) * wo[i, 2]
        lobe = (e[m] + 2.0) / (2.0 * np.pi) * max(c_alpha, 0.0) ** e[m]
        t = through(cos, coat, m)
        for c in range(3):
            out[i, c] += (kd[m, c] / np.pi + ks[m, c] * lobe) * li[j, c] * cos * t
