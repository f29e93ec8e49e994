"""Shading points (the camera's view of the scene, through mirrors and glass).

Ray queries go through :class:`blockhash.frame.scene_rays.SceneRays`: the photon tracer's embree
scene, or the photon kernels' device.  Perfect mirrors seen by the camera are resolved by
reflection: the pixel's shading point moves to what the mirror reflects, with the
mirror's reflectance as path weight (up to ``MAX_MIRROR_BOUNCES``); glass reflects or
refracts each shading point's ray by the Fresnel probabilities (up to
``MAX_DIELECTRIC_EVENTS``).  A one-sided receiver seen from behind shades nothing (black,
as Mitsuba's ``diffuse``), and one seen from the front takes light from its front only
(the normals face the camera, and the lights are shaded on the normal's side).  Direct light
is :mod:`.direct_light`'s.
"""

from __future__ import annotations

import numba
import numpy as np

from blockhash.frame.chain_end import emission_met
from blockhash.frame.glossy_rays import ray_pdf, rough_events, through_coat
from blockhash.frame.rough_direct import vertex_lights
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading_points import ShadingPoints
from blockhash.scene.materials import one_sided
from blockhash.scene.optics import choice_uniforms, scatter
from blockhash.scene.raycast import RAY_OFFSET

#: Mirror-to-mirror reflections followed for camera rays.
MAX_MIRROR_BOUNCES = 4
#: Specular events (mirror bounces, glass reflections and refractions) followed for camera
#: rays in a scene that holds a dielectric.
MAX_DIELECTRIC_EVENTS = 8
#: A branch of a camera ray split at glass is dropped when its weight falls below this in
#: every channel (the weight it carries is lost: at most this share of the sample's
#: radiance per dropped branch, against a floor or ball radiance of order 1).
BRANCH_CUTOFF = 1e-3
#: Seed of the camera rays' reflect-or-refract choices at glass (one stream, fixed, so an
#: image is the same in every run).
CAMERA_CHOICE_SEED = 0x9A55


def shading_points(camera, gbuffer, objects, rays: SceneRays, mirror_types, *,
                   both_branches: bool = False, events: int | None = None,
                   environment: bool = False, pass_index: int = 0,
                   lights=()) -> ShadingPoints:
    """Per-pixel shading points; a pixel that sees a mirror or glass follows the ray.

    At a mirror the ray reflects and its path weight takes the reflectance.  At glass
    (:class:`blockhash.scene.model.DielectricMaterial`) it reflects or refracts with the Fresnel
    probabilities (:func:`blockhash.scene.optics.scatter`, one branch per shading point, chosen by a fixed
    stream of uniforms per point, :data:`CAMERA_CHOICE_SEED`), its weight unchanged in
    expectation; a refraction multiplies it by the glass's tint.  With several samples per
    pixel (:mod:`.subpixel`) the pixel mean averages the branches.  A ray still on a
    specular surface after the last event, or leaving the scene, shades nothing, and so does
    one that meets the back face of a one-sided receiver
    (:attr:`blockhash.scene.materials.PhongMaterial.sided`): black, as Mitsuba's ``diffuse``.
    ``events``: the most specular events a ray follows (None: :data:`MAX_MIRROR_BOUNCES`, or
    :data:`MAX_DIELECTRIC_EVENTS` in a scene with glass; 0: a ray that meets a mirror or glass
    shades nothing); a ray still on a mirror, glass or glossy surface after them scatters once
    more and meets only lights (:mod:`.chain_end`, into :attr:`ShadingPoints.rough_direct`).
    With ``environment`` (the scene has an environment light) the rays that left the scene
    are marked (:attr:`ShadingPoints.escaped`), for the light they see.

    A rough mirror or glass (``alpha > 0``) sends the ray about a sampled microfacet
    (:mod:`blockhash.scene.microfacet`), drawn for pass ``pass_index`` (each pass its own),
    and meets the point, spot and directional ones of ``lights`` there by shadow rays
    (:attr:`ShadingPoints.rough_direct`, :mod:`.rough_direct`).

    With ``both_branches`` (the renderer's choice) a ray at glass follows both branches
    instead, the reflection weighted by the Fresnel reflectance F and the refraction by
    (1 - F) times the tint (:func:`branch_points`): no choice is drawn, so the glass is seen
    without speckle.  The points are then more than the samples, and
    :meth:`ShadingPoints.gather` sums each sample's.
    """
    geom = rays.geometry
    if geom.coat.any() or (both_branches and geom.is_dielectric.any()):  # a coat: always both
        return branch_points(camera, gbuffer, objects, rays, mirror_types, events,
                             environment=environment, pass_index=pass_index, lights=lights)

    h, w = gbuffer.object.shape
    glass, mirror, specular, reflectance, ior, tint = _surface_tables(objects, mirror_types, rays.geometry)
    backs = one_sided(objects)
    pos, nrm, obj, view, outer = _camera_start(camera, gbuffer, glass | backs, rays)
    escaped = obj < 0
    _no_back(obj, outer, backs)
    weight = np.ones((h * w, 3))
    choices = choice_uniforms(CAMERA_CHOICE_SEED, 0, h * w) if glass.any() else None
    if events is None:
        events = MAX_DIELECTRIC_EVENTS if glass.any() else MAX_MIRROR_BOUNCES
    met = None  # the light met at rough vertices and past the last event, per sample
    q = np.full(h * w, np.inf)  # the rays' rough_pdf (ShadingPoints)
    idx = np.flatnonzero(specular[obj])  # the rays on a specular surface, followed
    for event in range(events + 1):  # the last: a segment that ends on a light (.chain_end)
        if not len(idx):
            break
        wi = view[idx]
        n = nrm[idx]
        d = -wi
        r = 2.0 * np.sum(n * wi, axis=1, keepdims=True) * n - wi
        side = np.ones(len(idx))
        pdf = np.full(len(idx), np.inf)
        rough = rays.geometry.alpha[obj[idx]] > 0.0
        if rough.any():
            ri = idx[rough]
            if met is None:
                met = np.zeros((h * w, 3))
            met[ri] += weight[ri] * vertex_lights(rays, lights, pos[ri], n[rough], wi[rough],
                                                  obj[ri], outer[ri], ri, h * w, pass_index, event)
            r[rough], side[rough], pdf[rough] = rough_events(
                rays, ri, obj[ri], d[rough], n[rough], outer[ri], weight, pass_index, event)
        m = mirror[obj[idx]] & ~rough
        weight[idx[m]] *= reflectance(obj[idx[m]], np.sum(n[m] * wi[m], axis=1))
        g = ~m & ~rough
        if g.any():
            gi = idx[g]
            og = obj[gi]
            u = choices[gi, event % choices.shape[1]]
            r[g], through, factor = scatter(d[g], n[g], n[g], outer[gi], ior[og], tint[og], u)
            weight[gi] *= factor
            side[np.flatnonzero(g)[through]] = -1.0
        if event == events:
            if met is None:
                met = np.zeros((h * w, 3))
            p_end, _, o_end, _ = _follow(rays, pos[idx], n, r, side)
            emission_met(met, idx, weight[idx], p_end, -r, o_end, r, rays, lights, objects,
                         ray_pdf(pdf, pos[idx], p_end, o_end))
            break
        start = pos[idx]
        pos[idx], nrm[idx], obj[idx], outer[idx] = _follow(rays, start, n, r, side)
        q[idx] = ray_pdf(pdf, start, pos[idx], obj[idx])
        escaped[idx] = obj[idx] < 0
        obj[idx] = _no_back(obj[idx], outer[idx], backs)
        view[idx] = -r
        idx = idx[specular[obj[idx]]]  # the others' objects are not specular: they stay put
    obj[idx] = -1  # still on a specular surface after the last event: nothing to shade
    _textures(rays, objects, pos, nrm, view, obj, weight)
    return ShadingPoints(position=pos.reshape(h, w, 3).astype(np.float32),
                         normal=nrm.reshape(h, w, 3).astype(np.float32),
                         view=view.reshape(h, w, 3).astype(np.float32),
                         material=obj.reshape(h, w).astype(np.int32),
                         weight=weight.reshape(h, w, 3).astype(np.float32),
                         escaped=escaped.reshape(h, w) if environment and escaped.any()
                         else None,
                         rough_direct=met.reshape(h, w, 3) if met is not None and met.any()
                         else None,
                         rough_pdf=q.reshape(h, w) if np.isfinite(q).any() else None)


def _camera_start(camera, gbuffer, sided, rays: SceneRays):
    """The G-buffer's samples as flat float64 arrays: positions, normals, objects, unit
    directions toward the eye, and whether each hit on an object of ``sided`` (glass and
    one-sided receivers: (objects + 1,) bool) met its face's outer side (the G-buffer's
    ``front``, or where it has none the camera ray cast again; False elsewhere)."""
    pos = gbuffer.position.reshape(-1, 3).astype(np.float64)
    nrm = gbuffer.normal.reshape(-1, 3).astype(np.float64)
    obj = gbuffer.object.reshape(-1).copy()
    start = (np.broadcast_to(np.asarray(camera.eye, dtype=np.float64), pos.shape)
             if gbuffer.origin is None else gbuffer.origin.reshape(-1, 3))  # a lens's points
    view = _toward(start, pos)
    outer = np.zeros(len(obj), dtype=bool)
    first = np.flatnonzero(sided[obj])
    if gbuffer.front is not None:
        outer[first] = gbuffer.front.reshape(-1)[first]
    elif len(first):
        outer[first] = rays.first_hit(start[first].copy(), -view[first], sides=True)[5]
    return pos, nrm, obj, view, outer


@numba.njit(cache=True, nogil=True)
def _toward(start, pos):
    """(m, 3) unit directions from ``pos`` (m, 3) toward ``start`` ((m, 3), or a broadcast row),
    in one pass without temporaries (zero vectors stay zero)."""
    out = np.empty(pos.shape)
    for i in range(pos.shape[0]):
        v0 = start[i, 0] - pos[i, 0]
        v1 = start[i, 1] - pos[i, 1]
        v2 = start[i, 2] - pos[i, 2]
        r = max(np.sqrt((v0 * v0 + v1 * v1) + v2 * v2), 1e-30)
        out[i, 0], out[i, 1], out[i, 2] = v0 / r, v1 / r, v2 / r
    return out


def _textures(rays: SceneRays, objects, pos, nrm, view, obj, weight) -> None:
    """Scales ``weight`` (in place) at the points on textured receivers by the texture's value
    there over the material's ``kd`` (its mean: :mod:`blockhash.scene.texture`); each point's
    face and barycentrics from a ray cast back at it from just off the surface (as
    :func:`blockhash.frame.surface_lights.emission_seen` tells a side), or where that meets
    another surface first (a corner) along its normal."""
    geom = rays.geometry
    if not len(geom.textures):
        return
    on = np.flatnonzero(geom.texture_of[np.maximum(obj, 0)] >= 0)
    on = on[obj[on] >= 0]
    if not len(on):
        return
    lift = 8.0 * RAY_OFFSET * rays.scale
    hit, _, _, o, _, face, bary = rays.first_hit(pos[on] + view[on] * lift, -view[on], faces=True)
    again = np.flatnonzero(~hit | (o != obj[on]))  # in a corner: cast along the normal instead
    if len(again):
        n = nrm[on[again]]
        found = rays.first_hit(pos[on[again]] + n * lift, -n, faces=True)
        face[again], bary[again], o[again] = found[5], found[6], np.where(found[0], found[3], -1)
    ok = np.flatnonzero(o == obj[on])
    _, albedo = geom.albedo(face[ok], bary[ok, 0], bary[ok, 1])
    table = np.array([getattr(o.material, "kd", np.zeros(3)) for o in objects],
                     dtype=np.float64).reshape(-1, 3)
    kd = table[obj[on[ok]]]
    weight[on[ok]] *= np.divide(albedo, kd, out=np.zeros_like(albedo), where=kd > 0)


def _no_back(obj, outer, backs):
    """``obj`` (changed in place, and returned) with -1, nothing to shade, where a point lies
    on the back face (not ``outer``) of a one-sided receiver (``backs[obj]``)."""
    obj[backs[obj] & ~outer] = -1
    return obj


def _follow(rays: SceneRays, pos, nrm, dirs, side):
    """Rays leaving ``pos`` (lifted off the surface to the ``side`` (+1 or -1 per ray) of
    ``nrm``) along ``dirs``, to their next hit: (points, normals facing the ray, objects
    (-1: nothing hit), whether each met its face's outer side)."""
    origins = pos + nrm * (side * (RAY_OFFSET * rays.scale))[:, None]
    hit, p, sn, o, _, out_side = rays.first_hit(origins, dirs, sides=True)
    sn[np.sum(sn * -dirs, axis=1) < 0] *= -1
    return p, sn, np.where(hit, o, -1), out_side


class MirrorReflectance:
    """What a mirror reflects of a ray arriving at ``cos_i`` to its normal: its
    ``reflectance`` times a conductor's Fresnel reflectance
    (:class:`blockhash.scene.materials.MirrorMaterial`), from the per-object tables of the
    scene's ray caster (:class:`blockhash.scene.raycast.EmbreeGeometry`), which the photons'
    specular events read too."""

    def __init__(self, geometry):
        self.reflectance = geometry.reflectance
        self.conductor, self.eta, self.k = geometry.conductor, geometry.eta, geometry.k

    def __call__(self, obj, cos_i) -> np.ndarray:
        """(m, 3): the factors of rays on mirrors ``obj`` (m,) at ``cos_i`` (m,)."""
        from blockhash.scene.optics import conductor_fresnel

        out = self.reflectance[obj].copy()
        metal = self.conductor[obj]
        if metal.any():
            c = np.asarray(cos_i, dtype=np.float64)[metal, None]
            out[metal] *= conductor_fresnel(c, self.eta[obj[metal]], self.k[obj[metal]])
        return out


def _surface_tables(objects, mirror_types, geometry):
    """Per object, and one more entry for "nothing hit" (index -1): glass, mirror, specular
    masks, the mirrors' :class:`MirrorReflectance` (of ``geometry``, the objects' ray caster),
    ior (n,) and tint (n, 3)."""
    from blockhash.scene.model import DielectricMaterial

    glass = np.array([isinstance(o.material, DielectricMaterial) for o in objects] + [False])
    mirror = np.array([isinstance(o.material, mirror_types) for o in objects] + [False]) & ~glass
    reflectance = MirrorReflectance(geometry)
    ior = np.array([getattr(o.material, "ior", 1.0) for o in objects] + [1.0])
    tint = np.array([getattr(o.material, "tint", np.ones(3)) for o in objects] + [np.ones(3)],
                    dtype=np.float64).reshape(-1, 3)
    return glass, mirror, mirror | glass, reflectance, ior, tint


def branch_points(camera, gbuffer, objects, rays: SceneRays, mirror_types,
                  events: int | None = None, *, environment: bool = False,
                  pass_index: int = 0, lights=()) -> ShadingPoints:
    """Shading points of camera rays that follow both branches at glass
    (:func:`shading_points` with ``both_branches``): at each dielectric event a ray becomes
    a reflected ray of weight F and a refracted one of weight (1 - F) tint (one reflected
    ray of weight 1 under total internal reflection), each traced on, up to
    :data:`MAX_DIELECTRIC_EVENTS` events; a branch whose weight falls below
    :data:`BRANCH_CUTOFF` of its camera sample's (every channel) is dropped, and mirrors
    reflect as in :func:`shading_points`.  Only the points that shade a surface are kept
    (a branch that leaves the scene, or is still on a specular surface after the last event,
    adds nothing), laid out in rows of the G-buffer's width in the order they left the
    specular chain, padded with points that shade nothing; a one-sided receiver's back face
    shades nothing, as in :func:`shading_points`.  A rough mirror or glass does not branch:
    its ray takes one sampled microfacet, as in :func:`shading_points`.  A coated receiver
    (Mitsuba's ``plastic``, :mod:`blockhash.scene.coat`) is shaded through its coat (its
    weight times 1 - F toward the camera) and reflects a branch of weight F times the coat's
    reflectance, as glass does; those points are marked not the camera's first hit
    (:attr:`ShadingPoints.first_hit`)."""
    from blockhash.scene.optics import fresnel

    h, w = gbuffer.object.shape
    glass, mirror, specular, reflectance, ior, tint = _surface_tables(objects, mirror_types, rays.geometry)
    backs = one_sided(objects)
    pos, nrm, obj, view, outer = _camera_start(camera, gbuffer, glass | backs, rays)
    esc = obj < 0
    _no_back(obj, outer, backs)
    owner = np.arange(h * w)
    weight = np.ones((h * w, 3))
    q = np.full(h * w, np.inf)  # the rays' rough_pdf (ShadingPoints)
    done = []  # (owner, pos, nrm, view, obj, weight, escaped, first, q) of points off the chain
    met = np.zeros((h * w, 3))  # the light met at rough vertices, per sample
    coat = np.append(rays.geometry.coat, 0.0)  # index -1: nothing hit
    last = MAX_DIELECTRIC_EVENTS - 1 if events is None else events
    for event in range(last + 1):  # the last: a segment that ends on a light (.chain_end)
        on = specular[obj]
        shaded = through_coat(weight, nrm, view, obj, rays.geometry)
        done.append(tuple(a[~on] for a in (owner, pos, nrm, view, obj, shaded, esc))
                    + (np.full(int((~on).sum()), event == 0), q[~on]))
        on |= coat[obj] > 0.0  # a coated receiver: shaded through its coat, and reflects
        if not on.any():
            owner = owner[:0]
            break
        owner, pos, nrm, view, obj, weight, outer = (
            a[on] for a in (owner, pos, nrm, view, obj, weight, outer))
        d = -view
        refl = d - 2.0 * np.sum(d * nrm, axis=1, keepdims=True) * nrm
        g = glass[obj]
        f = np.ones(len(obj))
        f[g] = fresnel(-np.sum(d[g] * nrm[g], axis=1), np.where(outer[g], 1.0 / ior[obj[g]], ior[obj[g]]))
        # a mirror's reflectance; a coat's, its conductor of k = 0 (Fresnel's F) in the table
        w_refl = weight * np.where(g, f, 1.0)[:, None] * np.where(
            g[:, None], 1.0, reflectance(obj, -np.sum(d * nrm, axis=1)))
        rough = rays.geometry.alpha[obj] > 0.0
        rough_side = np.ones(len(obj))
        pdf = np.full(len(obj), np.inf)
        if rough.any():
            ri = np.flatnonzero(rough)
            np.add.at(met, owner[ri], weight[ri] * vertex_lights(
                rays, lights, pos[ri], nrm[ri], view[ri], obj[ri], outer[ri], owner[ri], h * w,
                pass_index, event))
            w_refl[ri] = weight[ri]  # one sampled branch, scaled by rough_events
            refl[ri], rough_side[ri], pdf[ri] = rough_events(
                rays, ri, obj[ri], d[ri], nrm[ri], outer[ri], w_refl, pass_index, event)
        through = np.flatnonzero(g & ~rough & (f < 1.0))
        t_dir, t_through, t_factor = scatter(d[through], nrm[through], nrm[through], outer[through],
                                             ior[obj[through]], tint[obj[through]],
                                             np.ones(len(through)))
        keep_t = through[t_through]
        w_refr = weight[keep_t] * (1.0 - f[keep_t])[:, None] * t_factor[t_through]
        parent = np.concatenate([np.arange(len(obj)), keep_t])
        dirs = np.concatenate([refl, t_dir[t_through]])
        wts = np.concatenate([w_refl, w_refr])
        side = np.concatenate([rough_side, -np.ones(len(keep_t))])
        pdf = np.concatenate([pdf, np.full(len(keep_t), np.inf)])
        live = wts.max(axis=1) >= BRANCH_CUTOFF
        parent, dirs, wts, side, pdf = parent[live], dirs[live], wts[live], side[live], pdf[live]
        start = pos[parent]
        pos, nrm, obj, outer = _follow(rays, start, nrm[parent], dirs, side)
        q = ray_pdf(pdf, start, pos, obj)
        if event == last:
            emission_met(met, owner[parent], wts, pos, -dirs, obj, dirs, rays, lights, objects, q)
            owner = owner[:0]
            break
        esc = obj < 0
        _no_back(obj, outer, backs)
        owner, view, weight = owner[parent], -dirs, wts
    # Rays still on a specular surface after the last event shade nothing, and are dropped;
    # so are those that left the scene, unless an environment light is seen along them.
    parts = [np.concatenate(col) for col in zip(*done)]
    _textures(rays, objects, *parts[1:6])
    shade = (parts[4] >= 0) | (parts[6] & environment)
    parts = [a[shade] for a in parts]
    m = len(parts[0])
    rows = max(-(-m // w), 1)  # one row at least: a pass needs a texture
    pad = rows * w - m
    own, p, n, v, o, wt, es, first, qs = (
        np.concatenate([a, np.zeros((pad,) + a.shape[1:], a.dtype)]) for a in parts)
    o[m:] = -1
    return ShadingPoints(position=p.reshape(rows, w, 3).astype(np.float32),
                         normal=n.reshape(rows, w, 3).astype(np.float32),
                         view=v.reshape(rows, w, 3).astype(np.float32),
                         material=o.reshape(rows, w).astype(np.int32),
                         weight=wt.reshape(rows, w, 3).astype(np.float32),
                         owner=own.astype(np.int64), samples=(h, w),
                         escaped=es.reshape(rows, w) if environment and es.any() else None,
                         rough_direct=met.reshape(h, w, 3) if met.any() else None,
                         first_hit=first.reshape(rows, w) if coat.any() else None,
                         rough_pdf=qs.reshape(rows, w) if np.isfinite(qs[:m]).any() else None)
