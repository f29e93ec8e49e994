"""Indirect photons: light after a diffuse bounce (stochastic progressive photon mapping's full
transport, as pbrt-v4's ``SPPMIntegrator`` stores it).

Photons leave every light over the whole scene, not only toward the specular objects: a
point or spot light uniformly inside the narrower of its own cone (the whole sphere for a
point light) and the cone that holds the scene's bounding sphere (a direction outside a
spot's cone carries nothing), an area light
from a point uniform by area in a cosine-distributed direction, a directional light from a
disc across its direction that covers the scene's bounding sphere, an environment light the
same across a direction drawn by its map's sampling
(:meth:`blockhash.scene.environment_light.EnvironmentLight.sample`, weight ``L / p`` times
the disc's area).  A light is chosen by its power (a directional light's: its irradiance over
that disc; an environment's: its radiance over the sphere times the disc), and a photon carries the
light's power over that probability, divided by the photons shot.  They follow mirrors and
glass as the caustic photons do (:func:`blockhash.photons.paths.specular_step`) and at a
diffuse (modified Phong) surface bounce on: a cosine-distributed direction about the shading
normal on the side they came from, the weight times ``pi f_r`` (``kd + ks (n + 2) / 2
cos^n alpha``), then Russian roulette with the survival probability the largest channel of
that factor (at most 1).  A photon is **stored at every diffuse vertex after its first**: the
first is direct light (the renderer's shadow rays) or, after a mirror or glass, the caustic
(the caustic photon map), so each path's light is counted once.  Paths end, as Mitsuba's of
the same depth, after ``max_bounces + 1`` surface events.

Random numbers are counter-based per photon, as the caustic photons': photon ``i`` of pass
``p`` reads its emission from Philox counter ``INDIRECT_COUNTER + p * PASS_STRIDE + i`` and
each bounce ``b`` from a key of its own, so a pass's photons are the same in any process.

:func:`needs_indirect` is the pilot that decides whether a scene has any: a scene whose
diffuse surfaces cannot light one another (no pilot photon leaving a diffuse surface meets
another diffuse surface next) traces none.
"""

from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np

from blockhash.photons.directions import frames, sample_cones
from blockhash.photons.emission import orthonormal_basis
from blockhash.photons.paths import CausticPhotons, compact, joined, specular_step
from blockhash.scene.optics import choice_uniforms
from blockhash.scene.raycast import RAY_OFFSET, EmbreeGeometry, entering, reflect, surface_hits

#: The indirect photons' counters start here (past any pass's caustic photons, below the area
#: lights' extra uniforms at 2^120).
INDIRECT_COUNTER = 1 << 100
#: Key offsets: bounce b draws from key seed + (b + 1) * BOUNCE_KEY; the area light's
#: direction from seed + EMIT_KEY; glass choices from seed + GLASS_KEY.
BOUNCE_KEY = 1 << 96
EMIT_KEY = 1 << 95
GLASS_KEY = 1 << 94
#: Photons of the pilot (:func:`needs_indirect`, and the share of photons per pass).
PILOT = 16384
#: Photons traced together (their arrays in flight: a few hundred bytes each a bounce).
BATCH = 1 << 18


def _uniforms(key: int, start: int, count: int) -> np.ndarray:
    bitgen = np.random.Philox(key=int(key) % (1 << 128), counter=INDIRECT_COUNTER + int(start))
    return np.random.Generator(bitgen).random((count, 4))


class IndirectSource:
    """A scene's lights emitting over the whole scene and the receivers' materials, built
    once: indirect photons from any stretch of the per-photon streams (module docstring), on
    ``device`` (:mod:`blockhash.device.choice`: :meth:`emit` runs the Dr.Jit kernels of
    :mod:`blockhash.device.indirect` there; the host's code, which :meth:`batch` and the light
    tracer use, is their oracle)."""

    def __init__(self, scene, geometry: EmbreeGeometry, device: str | None = None):
        from blockhash.device.choice import resolve
        from blockhash.scene.materials import material_arrays, receiver_materials

        self.scene, self.geometry = scene, geometry
        #: The streams' offset and the photons traced together (the device's kernels read them).
        self.counter, self.batch_size = INDIRECT_COUNTER, BATCH
        events = scene.photons.indirect_events
        self.max_events = int(scene.photons.max_bounces) + 1 if events is None else int(events)
        lo, hi = scene.bounds
        self.center = 0.5 * (lo + hi)
        self.radius = 0.5 * float(np.linalg.norm(hi - lo)) * (1.0 + 1e-6) + 1e-9
        self.lights = tuple(scene.lights)
        self.cones = [self._cone(li) for li in self.lights]
        self.power = np.array([self._power(li, c) for li, c in zip(self.lights, self.cones)])
        brightness = self.power.mean(axis=1)
        self.pmf = brightness / brightness.sum()
        self.cdf = np.cumsum(self.pmf)
        self.cdf[-1] = 1.0
        self.kd, self.ks, self.e = material_arrays(receiver_materials(scene.objects))
        self.device = resolve(device)
        self.kernels = None
        if self.device.jit:
            from blockhash.device.indirect import DeviceIndirectTracer

            self.kernels = DeviceIndirectTracer(self, self.device)

    def _cone(self, light):
        """(axis, cos of the half angle, intensity W/sr) a point or spot light's photons are
        shot into: the narrower of its own cone (the whole sphere for a point light) and the
        cone that holds the scene's bounding sphere from outside it (None for other lights)."""
        if not hasattr(light, "position"):
            return None
        cone = getattr(light, "cone_deg", None)
        power = np.asarray(light.power, dtype=np.float64)
        own_axis = np.asarray(getattr(light, "direction", (0.0, 0.0, 1.0)), dtype=np.float64)
        own_cos = -1.0 if cone is None else float(np.cos(np.radians(cone)))
        intensity = power / (4.0 * np.pi) if cone is None else light.peak_intensity
        to = self.center - np.asarray(light.position, dtype=np.float64)
        dist = float(np.linalg.norm(to))
        if dist <= self.radius:
            return own_axis, own_cos, intensity
        scene_cos = float(np.sqrt(1.0 - (self.radius / dist) ** 2)) - 1e-9
        if scene_cos > own_cos:
            return to / dist, scene_cos, intensity
        return own_axis, own_cos, intensity

    def _power(self, light, cone) -> np.ndarray:
        """The watts a light's photons carry: a directional light's over the disc, a point
        or spot light's into the cone it is sampled in."""
        if hasattr(light, "irradiance"):
            return np.asarray(light.irradiance) * np.pi * self.radius ** 2
        if hasattr(light, "image"):  # an environment: its light through the disc
            return np.asarray(light.integral) * np.pi * self.radius ** 2
        if cone is not None:
            return cone[2] * 2.0 * np.pi * (1.0 - cone[1])
        return np.asarray(light.power, dtype=np.float64)

    def emit(self, count: int, *, seed: int, start: int = 0) -> CausticPhotons:
        """Photons ``start .. start + count - 1`` shot; those stored at a second or later
        diffuse vertex, powers divided by ``count``."""
        if self.kernels is not None:
            return self.kernels.emit(count, seed=seed, start=start)
        t0 = time.perf_counter()
        chunks, counts = [], {}
        for got, c in self._batches(count, seed, start):
            chunks += [compact(*part[:5]) for part in got]  # the map's dtypes, batch by batch
            counts = {k: counts.get(k, 0) + v for k, v in c.items()}
        if chunks:
            pos, dirs, nrm, powers, obj = joined(chunks)
            powers /= np.float32(count)
        else:
            pos = dirs = nrm = powers = np.zeros((0, 3), dtype=np.float32)
            obj = np.zeros(0, dtype=np.int32)
        stats = {"emitted": count, "stored": len(pos), **counts,
                 "seconds": time.perf_counter() - t0}
        return CausticPhotons(pos, dirs, nrm, powers, count, stats, obj)

    def _batches(self, count: int, seed: int, start: int):
        """(stored parts, counts) of each :data:`BATCH` photons of ``start .. start + count
        - 1``, traced in turn."""
        for first in range(start, start + count, BATCH):
            n = min(BATCH, start + count - first)
            o, d, w = self._emission(seed, first, n)
            yield self._trace(o, d, w, seed, first)

    def batch(self, count: int, *, seed: int, start: int = 0) -> SimpleNamespace:
        """The stored photons of photons ``start .. start + count - 1`` as the light tracer
        connects them (:func:`blockhash.reference.lighttrace.light_trace`): positions,
        directions, shading and geometric normals (on the side the photon came from),
        weights not yet divided by the photons shot, objects, and the paths' counts.  Traced
        :data:`BATCH` photons at a time (each photon's numbers are its own, so the result does
        not depend on it)."""
        parts, counts = [], {}
        for got, c in self._batches(count, seed, start):
            parts += got
            counts = {k: counts.get(k, 0) + v for k, v in c.items()}
        if parts:
            pos, dirs, nrm, wts, obj, ng = (np.concatenate(a) for a in zip(*parts))
        else:
            z = np.zeros((0, 3))
            pos, dirs, nrm, wts, ng = z, z.copy(), z.copy(), z.copy(), z.copy()
            obj = np.zeros(0, np.int64)
        return SimpleNamespace(positions=pos, directions=dirs, normals=nrm, weights=wts,
                               objects=obj.astype(np.int64), geo_normals=ng,
                               stored=np.arange(len(pos)), counts=counts)

    # ------------------------------------------------------------------ emission

    def _emission(self, seed: int, start: int, n: int):
        u = _uniforms(seed, start, n)
        k = np.minimum(np.searchsorted(self.cdf, u[:, 0], side="right"), len(self.lights) - 1)
        o, d, w = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        extra = None
        for li, light in enumerate(self.lights):
            rows = np.flatnonzero(k == li)
            if not len(rows):
                continue
            u1, u2 = u[rows, 1], u[rows, 2]
            w[rows] = self.power[li] / self.pmf[li]
            if hasattr(light, "irradiance"):  # a disc across the direction, upstream
                D = np.asarray(light.direction, dtype=np.float64)
                o[rows] = self._disc(D, *orthonormal_basis(D), u1, u2)
                d[rows] = D
            elif hasattr(light, "image"):  # an environment: a direction by its map, then a disc
                if extra is None:
                    extra = _uniforms(seed + EMIT_KEY, start, n)
                toward, p = light.sample(extra[rows, 0], extra[rows, 1], extra[rows, 2])
                D = -toward
                o[rows] = self._disc(D, *frames(D), u1, u2)
                d[rows] = D
                w[rows] = (light.emitted(toward) / p[:, None]) * (np.pi * self.radius ** 2
                                                                   / self.pmf[li])
            elif hasattr(light, "radiance"):  # a point by area, a cosine direction
                if extra is None:
                    extra = _uniforms(seed + EMIT_KEY, start, n)
                o[rows], normals = light.points(u[rows, 3], u1, u2)
                d[rows] = _cosine(normals, extra[rows, 0], extra[rows, 1])
                if light.texture is not None:  # the radiance there over its mean
                    w[rows] *= np.divide(light.emitted_at(u[rows, 3], u1, u2), light.radiance,
                                         out=np.zeros((len(rows), 3)), where=light.radiance > 0)
            else:  # point or spot: uniform in solid angle inside the cone of _cone
                axis, cos_c, _ = self.cones[li]
                t1, t2 = orthonormal_basis(axis)
                m = len(rows)
                d[rows] = sample_cones(np.tile(axis, (m, 1)), np.tile(t1, (m, 1)),
                                       np.tile(t2, (m, 1)), np.full(m, cos_c), u1, u2)
                o[rows] = light.position
                cone = getattr(light, "cone_deg", None)
                if cone is not None:  # aimed at the scene: outside the spot's cone is dark
                    cos = d[rows] @ np.asarray(light.direction)
                    w[rows[cos < np.cos(np.radians(cone)) - 1e-12]] = 0.0
                    if not light.uniform:  # the beam's falloff toward the cone's edge
                        w[rows] *= light.falloff(cos)[:, None]
                    if light.texture is not None:  # a texture projected across the cone
                        w[rows] *= light.texture_factor(d[rows])
        return o, d, w

    def _disc(self, D, t1, t2, u1, u2) -> np.ndarray:
        """(n, 3) origins uniform on the disc of the scene's bounding sphere across ``D`` ((3,)
        or (n, 3), frame ``t1``, ``t2``), upstream of the scene, from uniforms ``u1``, ``u2``."""
        rho, phi = self.radius * np.sqrt(u1), 2.0 * np.pi * u2
        return (self.center - 2.0 * self.radius * D + (rho * np.cos(phi))[:, None] * t1
                + (rho * np.sin(phi))[:, None] * t2)

    # ------------------------------------------------------------------ paths

    def _trace(self, o, d, w, seed: int, start: int):
        geom = self.geometry
        n = len(o)
        idx = np.arange(n)
        diffuse_seen = np.zeros(n, dtype=np.int64)  # diffuse vertices so far
        choices = choice_uniforms(seed + GLASS_KEY, start, n) if geom.draws else None
        events = np.zeros(n, dtype=np.int64)
        fallbacks = np.zeros(n, dtype=np.uint16)
        offset = RAY_OFFSET * geom.scale
        o = o + d * offset
        parts = []
        counts = {"escaped": 0, "absorbed": 0, "roulette": 0, "max_events": 0, "rays_cast": 0}
        for event in range(self.max_events):
            if not idx.size:
                break
            counts["rays_cast"] += int(idx.size)
            hit, face, u, v = geom.intersect(o, d)
            counts["escaped"] += int((~hit).sum())
            idx, d, w = idx[hit], d[hit], w[hit]  # face, u, v: the hits' only
            obj = geom.face_object[face]
            spec = geom.is_specular[obj]
            diff = np.flatnonzero(~spec)
            back = geom.one_sided[obj[diff]] & ~entering(geom, face[diff], d[diff])
            counts["absorbed"] += int(back.sum())
            diff = diff[~back]
            p, ns, ng = surface_hits(geom, face[diff], u[diff], v[diff], d[diff])
            new = []
            if geom.coat.any():  # a coat reflects by Fresnel: a specular event, not a vertex
                glint = self._coats(idx[diff], d[diff], w[diff], obj[diff], p, ns, ng, choices,
                                    events, counts)
                if glint is not None:
                    keep, part = glint
                    diff, p, ns, ng = diff[keep], p[keep], ns[keep], ng[keep]
                    if event < self.max_events - 1:
                        new.append(part)
                    else:
                        counts["max_events"] += len(part[0])
            store = diffuse_seen[idx[diff]] >= 1
            if store.any():
                parts.append((p[store], d[diff][store], ns[store], w[diff][store],
                              obj[diff][store], ng[store]))
            diffuse_seen[idx[diff]] += 1
            last = event == self.max_events - 1
            if len(diff) and not last:
                new.append(self._bounce(idx[diff], d[diff], w[diff], obj[diff], p, ns, ng,
                                        seed, start, event, counts,
                                        (face[diff], u[diff], v[diff])))
            sp = np.flatnonzero(spec)
            if len(sp) and not last:
                absorbed, (si, sd, sw, spn, sng, side) = specular_step(
                    geom, idx[sp], d[sp], w[sp], face[sp], u[sp], v[sp], choices, events,
                    fallbacks)
                counts["absorbed"] += len(absorbed)
                new.append((si, sd, sw, spn + sng * (side * offset)[:, None]))
            if last:
                counts["max_events"] += len(diff) + len(sp)
            if not new:
                break
            idx, d, w, o = (np.concatenate(a) for a in zip(*new))
        return parts, counts

    def _coats(self, idx, d, w, obj, p, ns, ng, choices, events, counts):
        """The coat's reflections (:mod:`blockhash.scene.coat`) among diffuse hits: each on a
        coated receiver reflects with Fresnel's probability (a rough coat with its table's,
        about a sampled microfacet; the choices from ``choices``).
        None where none does, else (the hits that stay diffuse, (idx, reflected directions,
        weights times the coat's reflectance, new origins) of those that reflect)."""
        from blockhash.scene.coat import transmittance
        from blockhash.scene.microfacet import UNIFORMS, rough_scatter

        geom = self.geometry
        coat = geom.coat[obj]
        on = np.flatnonzero(coat > 0.0)
        if not len(on):
            return None
        width = choices.shape[1]
        uc = choices[idx[on], events[idx[on]] % width]
        events[idx[on]] += 1
        cos = -np.einsum("ij,ij->i", d[on], ns[on])
        t = transmittance(cos, geom.mirror, obj[on])
        hit = uc >= t
        glint, p_glint = on[hit], 1.0 - t[hit]
        if not len(glint):
            return None
        r = reflect(d[glint], ns[glint])
        wrong = np.einsum("ij,ij->i", r, ng[glint]) <= 0.0
        r[wrong] = reflect(d[glint][wrong], ng[glint][wrong])
        wg = w[glint] * geom.coat_reflectance[obj[glint]]
        rough = np.flatnonzero(geom.alpha[obj[glint]] > 0.0)
        if len(rough):  # a rough coat: a rough conductor of its index, over the choice's odds
            ids = idx[glint[rough]]
            u = choices[ids[:, None], (events[ids][:, None] + np.arange(UNIFORMS)) % width]
            events[ids] += UNIFORMS
            g = glint[rough]
            r[rough], factor, _ = rough_scatter(d[g], ns[g], ng[g], np.ones(len(g), dtype=bool),
                                                obj[g], geom.mirror, geom.is_dielectric,
                                                geom.ior, u)
            wg[rough] = w[g] * factor / p_glint[rough, None]
        keep = np.ones(len(idx), dtype=bool)
        keep[glint] = False
        offset = RAY_OFFSET * geom.scale
        live = wg.max(axis=1) > 0.0  # a rough coat's microfacet may send it in: absorbed
        counts["absorbed"] += int((~live).sum())
        return keep, (idx[glint][live], r[live], wg[live], p[glint][live] + ng[glint][live] * offset)

    def _bounce(self, idx, d, w, obj, p, ns, ng, seed, start, event, counts, hits=None):
        """A diffuse bounce: cosine-distributed about the shading normal on the incoming side
        (the geometric normal where the shading normal leans past it), weight times pi f_r
        and Russian roulette (module docstring); ``hits`` (face, u, v) where the photons are,
        for a textured receiver's reflectance there."""
        u = _uniforms(seed + (event + 1) * BOUNCE_KEY, start, 0 if not len(idx) else int(idx.max()) + 1)
        u = u[idx]
        up = np.where((np.einsum("ij,ij->i", ns, ng) > 0.0)[:, None], ns, ng)
        wo = _cosine(up, u[:, 0], u[:, 1])
        under = np.einsum("ij,ij->i", wo, ng) <= 0.0
        wi = -d
        cos_n = np.einsum("ij,ij->i", wo, up)
        refl = 2.0 * np.einsum("ij,ij->i", wi, up)[:, None] * up - wi
        c_alpha = np.maximum(np.einsum("ij,ij->i", refl, wo), 0.0)
        e = self.e[obj]
        lobe = (e + 2.0) / 2.0 * c_alpha ** e
        kd = self.kd[obj]
        if hits is not None and len(self.geometry.textures):
            textured, albedo = self.geometry.albedo(*hits)
            kd[textured] = albedo[textured]
        factor = kd + self.ks[obj] * lobe[:, None]
        coat = self.geometry.coat[obj]
        if coat.any():  # what leaves a coated base passes its coat: (1 - F) on the way out
            from blockhash.scene.coat import transmittance

            on = coat > 0.0
            factor[on] *= transmittance(cos_n[on], self.geometry.mirror, obj[on])[:, None]
        factor[under | (cos_n <= 0.0)] = 0.0
        q = np.minimum(factor.max(axis=1), 1.0)
        live = u[:, 2] < q
        counts["roulette"] += int((~live).sum())
        w = w[live] * factor[live] / q[live, None]
        offset = RAY_OFFSET * self.geometry.scale
        return idx[live], wo[live], w, p[live] + ng[live] * offset


def _cosine(normals: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> np.ndarray:
    """(n, 3) directions cosine-distributed about unit ``normals`` (Malley's method)."""
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    t1, t2 = frames(normals)
    z = np.sqrt(np.maximum(1.0 - u1, 0.0))
    return ((r * np.cos(phi))[:, None] * t1 + (r * np.sin(phi))[:, None] * t2
            + z[:, None] * normals)


def needs_indirect(source: IndirectSource, seed: int):
    """(the pilot's indirect photon map, None where the scene's diffuse surfaces cannot light
    one another; the pilot's counts): a scene needs indirect photons when one of
    :data:`PILOT` photons shot as a pass's are, leaving a diffuse surface, meets another
    diffuse surface next (not over a mirror or glass: light refocused by a mirror onto the
    surface it left, L D S+ D, is a mirror's second-order light, left to a scene that also has
    diffuse-to-diffuse light); the map is the pass-0 stretch of the streams, ``PILOT`` photons
    shot, for the caller's share of photons."""
    geom = source.geometry
    o, d, w = source._emission(seed, 0, PILOT)
    offset = RAY_OFFSET * geom.scale
    hit, face, u, v = geom.intersect(o + d * offset, d)
    diff = ~geom.is_specular[geom.face_object[face]]  # face, u, v: the hits' only
    rows = np.flatnonzero(hit)[diff]
    if not len(rows):
        return None, {"pilot": PILOT, "diffuse_to_diffuse": 0}
    f = face[diff]
    p, ns, ng = surface_hits(geom, f, u[diff], v[diff], d[rows])
    counts = {"roulette": 0}
    idx, wo, _, start = source._bounce(rows, d[rows], w[rows], geom.face_object[f], p, ns, ng,
                                       seed, 0, 0, counts, (f, u[diff], v[diff]))
    hit2, face2, _, _ = geom.intersect(start, wo)
    second = ~geom.is_specular[geom.face_object[face2]]
    dd = int(second.sum())
    return (source.emit(PILOT, seed=seed, start=0) if dd else None), {
        "pilot": PILOT, "diffuse_to_diffuse": dd}
