"""A probe before committing to Dr.Jit: caustic photons traced by blockhash's own tracer
(numba + embree, float64) against the same photons written as vectorised Dr.Jit code over
Mitsuba 3's scene (LLVM backend here, ``llvm_ad_rgb``, float32; the same Python would run on
CUDA/OptiX with a ``cuda_*`` variant), on the same scene in the same process.

For each scene of ``--scenes``:

1. blockhash: :func:`blockhash.photons.tracing.trace_caustic_photons` to ``--photons`` stored
   photons, once cold (numba's compile or its on-disk cache) and then ``--repeat`` times; the
   median's stored photons per second, stored per emitted, and the caustic flux.  Its time
   includes what the entry point builds each call (embree's BVH, the emitter's cones and
   projection maps: ``setup_s`` in the JSON is that part alone).
2. Dr.Jit: the scene exported (:func:`blockhash.scene.mitsuba.exporter.export_mitsuba`, modified
   Phong lobes dropped, which changes nothing here: receivers store photons whatever their
   BSDF) and loaded with ``mi.load_file``; photons emitted, traced and stored in one symbolic
   ``while`` loop (``@dr.syntax``), compacted with ``dr.compress``.  The emission uses the
   *project's* emitter tables (:class:`blockhash.photons.emission.Emitter`, built once outside
   the clock): the same pmf over cones and targets, point lights' bounding cones with their
   projection maps' live cells (and the mixture density over a light's cones), spot cones'
   zero weight outside, area lights' uniform point and cone toward each target's bounding
   sphere, a directional light's discs upstream; so stored/emitted should match blockhash's.
   The photon count is blockhash's emitted per stored times ``--photons``, one launch; the
   first (cold) run compiles the kernels (Dr.Jit also keeps them on disk, ``~/.drjit``: a
   second process finds them there), then the median of ``--repeat`` warm runs, each ending
   with ``dr.sync_thread()``.

What the Dr.Jit version models: a miss ends the photon; a diffuse first hit is dropped
(direct light); a diffuse hit after >= 1 specular event is stored (position, power), except
on the back face of a one-sided receiver (absorbed); a mirror reflects about the shading
normal (its reflectance on the power), falling back to the geometric normal when the shading
normal sends the photon into the surface; glass reflects with probability ``mi.fresnel`` (the
relative index from which side of the geometric normal the photon comes) and otherwise
refracts (``mi.refract``, its tint on the power), with the same fallback; a specular hit past
the scene's ``max_bounces`` ends the photon; new rays start at ``si.spawn_ray``.  Material
parameters are per shape (gathered by the shape's registry index), taken from the blockhash
scene.

What it leaves out: blockhash's stopping rule (the (n+1)-th stored photon ends the run: here
a fixed photon count, so the stored count is only near ``--photons``), its Philox streams
(PCG32 here, so the photons are not the same ones), the stored directions, normals and
receiving object, per-photon fates and statistics, float64, blockhash's ray offset after a
bounce (Mitsuba's ``spawn_ray`` offset instead), the projection maps' and emitter's setup
(reused, not timed), and every bias check beyond stored/emitted and the total flux.

usage: python tools/drjit_trace_probe.py [--scenes ring,sun,cbox] [--photons 1000000]
                                         [--repeat 3] [--loop symbolic] [--json FILE]
"""

import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from blockhash.photons.light_targets import INSIDE
from blockhash.photons.tracing import PhotonSource, trace_caustic_photons
from blockhash.scene.loader import load_scene
from blockhash.scene.mitsuba.exporter import export_mitsuba
from blockhash.scene.model import AreaLight, DielectricMaterial, DirectionalLight, MirrorMaterial
from blockhash.studies.command import ToolParser, count, write_json

#: Shape kinds in the Dr.Jit tables.
DIFFUSE, MIRROR, GLASS = 0, 1, 2
#: The projection maps' cells per side (blockhash.photons.emission.MAP_CELLS).
CELLS = 128
#: Slack of float32 cone membership tests (the project's is 1e-12 in float64).
CONE_EPS = 1e-6


def blockhash_runs(scene, photons: int, repeat: int) -> dict:
    """The project's tracer: cold run, then ``repeat`` warm ones (seeds 2, 3, ...)."""
    t = time.perf_counter()
    trace_caustic_photons(scene, photons, seed=1)
    cold = time.perf_counter() - t
    times, maps = [], []
    for r in range(repeat):
        t = time.perf_counter()
        maps.append(trace_caustic_photons(scene, photons, seed=2 + r))
        times.append(time.perf_counter() - t)
    t = time.perf_counter()
    PhotonSource(scene)
    setup = time.perf_counter() - t
    sec = statistics.median(times)
    m = maps[times.index(sorted(times)[(len(times) - 1) // 2])]
    stored, emitted = len(m.positions), int(m.emitted)
    return {"cold_s": cold, "warm_s": times, "median_s": sec, "setup_s": setup,
            "stored": stored, "emitted": emitted, "stored_per_s": stored / sec,
            "emitted_per_s": emitted / sec, "stored_per_emitted": stored / emitted,
            "rays_cast": int(m.stats.get("rays_cast", 0)),
            "flux": [float(x) for x in m.total_power]}


# --------------------------------------------------------------------------- Dr.Jit side

class DrjitTracer:
    """The Mitsuba scene of ``scene`` and the project's emitter tables as Dr.Jit arrays."""

    def __init__(self, mi, dr, scene, workdir: Path):
        self.mi, self.dr = mi, dr
        t = time.perf_counter()
        xml = export_mitsuba(scene, workdir, drop_specular=True)
        self.mscene = mi.load_file(str(xml))
        self.load_s = time.perf_counter() - t
        source = PhotonSource(scene)
        if source.emitter is None:
            raise SystemExit(f"{scene.path}: no light reaches a specular object")
        self.emitter = em = source.emitter
        self.lights = tuple(scene.lights)
        self.max_bounces = int(source.max_bounces)
        self.offset = 1e-5 * float(source.geometry.scale)  # blockhash.scene.raycast.RAY_OFFSET
        self.bounds = np.asarray(scene.bounds, dtype=np.float64)
        self._shape_tables(scene)
        self.n_cones = len(em.cones)
        if self.n_cones:
            self._cone_tables()

    # ---- tables
    def _shape_tables(self, scene):
        mi, dr = self.mi, self.dr
        # By BSDF id, the exporter's "NAME-bsdf" of a material's first object: Mitsuba merges
        # the shapes that share a BSDF into one mesh whose shape id is empty.
        by_bsdf = {f"{o.name}-bsdf": o.material for o in reversed(scene.objects)}
        shapes = list(self.mscene.shapes())
        ids = [int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(s))[0]) for s in shapes]
        n = max(ids) + 1
        kind = np.zeros(n, np.uint32)
        one_sided = np.zeros(n, np.uint32)
        refl = np.ones((n, 3), np.float32)
        ior = np.ones(n, np.float32)
        for s, i in zip(shapes, ids):
            mat = by_bsdf[s.bsdf().id()]
            if isinstance(mat, MirrorMaterial):
                kind[i], refl[i] = MIRROR, mat.reflectance
            elif isinstance(mat, DielectricMaterial):
                kind[i], refl[i], ior[i] = GLASS, mat.tint, mat.ior
            else:
                one_sided[i] = bool(getattr(mat, "one_sided", False))
        self.kind_t, self.one_sided_t = mi.UInt32(kind), mi.UInt32(one_sided)
        self.refl_t, self.ior_t = mi.Float(refl.reshape(-1)), mi.Float(ior)

    def _cone_tables(self):
        mi = self.mi
        cones = self.emitter.cones
        f32 = lambda a: mi.Float(np.asarray(a, np.float32).reshape(-1))  # noqa: E731
        self.c_axis = f32([c.axis for c in cones])
        self.c_t1 = f32([c.t1 for c in cones])
        self.c_t2 = f32([c.t2 for c in cones])
        self.c_cos = f32([c.cos_half for c in cones])
        self.c_pos = f32([self.emitter.positions[c.light] for c in cones])
        self.c_int = f32([self.emitter.intensity[c.light] for c in cones])
        self.c_density = [float(self.emitter.pmf[j] / (c.solid_angle * c.live_fraction))
                          for j, c in enumerate(cones)]
        self.c_dens_t = f32(self.c_density)
        cells, offsets, counts, live = [], [], [], []
        for c in cones:
            lc = c.live_cells if c.live is not None else np.zeros(0, np.int64)
            offsets.append(sum(len(x) for x in cells))
            counts.append(len(lc))
            cells.append(lc)
            live.append(c.live.reshape(-1) if c.live is not None
                        else np.ones(CELLS * CELLS, bool))
        self.c_cells = mi.UInt32(np.concatenate(cells + [np.zeros(1, np.int64)]).astype(np.uint32))
        self.c_off = mi.UInt32(np.array(offsets, np.uint32))
        self.c_cnt = mi.UInt32(np.array(counts, np.uint32))
        self.c_live = mi.UInt32(np.concatenate(live).astype(np.uint32))

    # ---- emission
    def _cones(self, k, u1, u2, u3):
        """Origin, direction, weight of a photon on cone ``k`` (the emitter's _sample_cones)."""
        mi, dr = self.mi, self.dr
        g = lambda t, src: dr.gather(t, src, k)  # noqa: E731
        axis, t1, t2 = g(mi.Vector3f, self.c_axis), g(mi.Vector3f, self.c_t1), g(mi.Vector3f, self.c_t2)
        cos_h = g(mi.Float, self.c_cos)
        cnt = g(mi.UInt32, self.c_cnt)
        mapped = cnt > 0
        slot = dr.minimum(mi.UInt32(u3 * mi.Float(cnt)), dr.maximum(cnt, 1) - 1)
        cell = dr.gather(mi.UInt32, self.c_cells, g(mi.UInt32, self.c_off) + slot, mapped)
        u1 = dr.select(mapped, (mi.Float(cell // CELLS) + u1) / CELLS, u1)
        u2 = dr.select(mapped, (mi.Float(cell % CELLS) + u2) / CELLS, u2)
        cos_t = 1.0 - u1 * (1.0 - cos_h)
        sin_t = dr.safe_sqrt(1.0 - cos_t * cos_t)
        sin_p, cos_p = dr.sincos(2.0 * dr.pi * u2)
        d = dr.normalize(cos_t * axis + (sin_t * cos_p) * t1 + (sin_t * sin_p) * t2)
        q = g(mi.Float, self.c_dens_t)
        cones = self.emitter.cones
        for j, c in enumerate(cones):  # the other cones of the same light that hold d
            others = [i for i, ci in enumerate(cones) if ci.light == c.light and i != j]
            if not others:
                continue
            mine = dr.zeros(mi.Bool, dr.width(k))
            for i in others:
                mine |= k == i
            a, ta, tb = (mi.Vector3f(*map(float, v)) for v in (c.axis, c.t1, c.t2))
            ca = dr.dot(d, a)
            inside = mine & (ca >= c.cos_half - CONE_EPS)
            if c.live is not None:
                uu = (1.0 - ca) / max(1.0 - c.cos_half, 1e-30)
                phi = dr.atan2(dr.dot(d, tb), dr.dot(d, ta))
                phi = dr.select(phi < 0, phi + 2.0 * dr.pi, phi)
                ci = dr.clip(mi.Int32(uu * CELLS), 0, CELLS - 1)
                cj = dr.clip(mi.Int32(phi / (2.0 * dr.pi) * CELLS), 0, CELLS - 1)
                flat = mi.UInt32(j * CELLS * CELLS + ci * CELLS + cj)
                inside &= dr.gather(mi.UInt32, self.c_live, flat, inside) != 0
            q += dr.select(inside, self.c_density[j], 0.0)
        w = g(mi.Color3f, self.c_int) / q
        o = g(mi.Point3f, self.c_pos)
        for li, light in enumerate(self.lights):  # spot cones: nothing outside
            s_axis = self.emitter.spot_axis[li]
            if s_axis is None:
                continue
            here = dr.zeros(mi.Bool, dr.width(k))
            for j, c in enumerate(cones):
                if c.light == li:
                    here |= k == j
            out = here & (dr.dot(d, mi.Vector3f(*map(float, s_axis)))
                          < self.emitter.spot_cos[li] - CONE_EPS)
            w = dr.select(out, 0.0, w)
        return o, d, w

    def _target_mixture(self, t, rows, inside_of):
        """q = sum over targets ``rows`` of pmf_j [inside_j] / measure_j (own target always)."""
        mi, dr = self.mi, self.dr
        q = dr.zeros(mi.Float, dr.width(t))
        for j in rows:
            inside, density = inside_of(j)
            q += dr.select((t == j) | inside, density, 0.0)
        return q

    def _area(self, li, light, t, u1, u2, e0, e1, e2):
        mi, dr = self.mi, self.dr
        tri = mi.Float(np.asarray(light.triangles, np.float32).reshape(-1))
        fnorm = mi.Float(np.asarray(light.face_normals, np.float32).reshape(-1))
        dist = mi.DiscreteDistribution(mi.Float(np.asarray(light.face_areas, np.float32)))
        f = dist.sample(e0)
        s = dr.sqrt(e1)
        b0, b2 = 1.0 - s, s * e2
        p = [dr.gather(mi.Point3f, tri, f * 3 + c) for c in range(3)]
        y = b0 * p[0] + (1.0 - b0 - b2) * p[1] + b2 * p[2]
        ny = dr.gather(mi.Vector3f, fnorm, f)
        tg = self.emitter.targets
        rows = [j for j, x in enumerate(tg) if x.light == li]

        def cone(j):
            c = mi.Point3f(*map(float, tg[j].center))
            to = c - y
            dd = dr.norm(to)
            inside = dd <= tg[j].radius * INSIDE
            axis = dr.select(inside, mi.Vector3f(0, 0, 1), to / dr.maximum(dd, 1e-30))
            sin2 = dr.select(inside, 1.0, dr.square(tg[j].radius / dr.maximum(dd, 1e-30)))
            cos_h = dr.select(inside, -1.0, dr.safe_sqrt(1.0 - sin2))
            return axis, cos_h

        axis = mi.Vector3f(0, 0, 1)
        cos_h = mi.Float(-1.0)
        for j in rows:
            a, ch = cone(j)
            axis, cos_h = dr.select(t == j, a, axis), dr.select(t == j, ch, cos_h)
        cos_t = 1.0 - u1 * (1.0 - cos_h)
        sin_t = dr.safe_sqrt(1.0 - cos_t * cos_t)
        sin_p, cos_p = dr.sincos(2.0 * dr.pi * u2)
        fr = mi.Frame3f(axis)
        d = dr.normalize(fr.to_world(mi.Vector3f(sin_t * cos_p, sin_t * sin_p, cos_t)))

        def inside_of(j):
            a, ch = cone(j)
            return (dr.dot(d, a) >= ch - CONE_EPS,
                    float(self.emitter.pmf[self.n_cones + j]) / (2.0 * dr.pi * (1.0 - ch)))

        q = self._target_mixture(t, rows, inside_of)
        cos_y = dr.maximum(dr.dot(d, ny), 0.0)
        w = mi.Color3f(*map(float, light.radiance)) * (cos_y * float(light.area) / q)
        return y, d, w

    def _directional(self, li, light, t, u1, u2):
        mi, dr = self.mi, self.dr
        from blockhash.photons.directions import orthonormal_basis

        D = np.asarray(light.direction, np.float64)
        D = D / np.linalg.norm(D)
        t1, t2 = orthonormal_basis(D)
        lo, hi = self.bounds
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        s0 = float((corners @ D).min()) - 1e-3 * max(float(np.linalg.norm(hi - lo)), 1e-9)
        tg = self.emitter.targets
        rows = [j for j, x in enumerate(tg) if x.light == li]
        ca = dr.zeros(mi.Float, dr.width(t))
        cb = dr.zeros(mi.Float, dr.width(t))
        r = dr.zeros(mi.Float, dr.width(t))
        for j in rows:
            sel = t == j
            ca = dr.select(sel, float(tg[j].center @ t1), ca)
            cb = dr.select(sel, float(tg[j].center @ t2), cb)
            r = dr.select(sel, float(tg[j].radius), r)
        rho = r * dr.sqrt(u1)
        sin_p, cos_p = dr.sincos(2.0 * dr.pi * u2)
        a, b = ca + rho * cos_p, cb + rho * sin_p

        def inside_of(j):
            da, db = a - float(tg[j].center @ t1), b - float(tg[j].center @ t2)
            rr = float(tg[j].radius) ** 2
            return da * da + db * db <= rr * (1.0 + 1e-6), float(self.emitter.pmf[self.n_cones + j]) / (math.pi * rr)

        q = self._target_mixture(t, rows, inside_of)
        vec = lambda v: mi.Vector3f(*map(float, v))  # noqa: E731
        o = mi.Point3f(a * vec(t1) + b * vec(t2) + s0 * vec(D))
        d = dr.zeros(mi.Vector3f, dr.width(t)) + vec(D)
        w = mi.Color3f(*map(float, light.irradiance)) / q
        return o, d, w

    def emit(self, rng):
        """Origins, directions and weights of the photons of ``rng``'s lanes."""
        mi, dr = self.mi, self.dr
        n = dr.width(rng.state)
        u0, u1, u2, u3 = (rng.next_float32() for _ in range(4))
        e0, e1, e2 = (rng.next_float32() for _ in range(3))
        k = dr.zeros(mi.UInt32, n)
        for c in self.emitter.cdf[:-1]:
            k += dr.select(u0 >= float(c), 1, 0)
        k = dr.minimum(k, self.emitter.sources - 1)
        o, d, w = dr.zeros(mi.Point3f, n), dr.zeros(mi.Vector3f, n) + mi.Vector3f(0, 0, 1), \
            dr.zeros(mi.Color3f, n)
        if self.n_cones:
            oc, dc, wc = self._cones(dr.minimum(k, self.n_cones - 1), u1, u2, u3)
            sel = k < self.n_cones
            o, d, w = dr.select(sel, oc, o), dr.select(sel, dc, d), dr.select(sel, wc, w)
        t = k - self.n_cones  # wraps for cone photons; they match no target below
        for li, light in enumerate(self.lights):
            rows = [j for j, x in enumerate(self.emitter.targets) if x.light == li]
            if not rows:
                continue
            if isinstance(light, AreaLight):
                ol, dl, wl = self._area(li, light, t, u1, u2, e0, e1, e2)
            elif isinstance(light, DirectionalLight):
                ol, dl, wl = self._directional(li, light, t, u1, u2)
            else:
                continue
            sel = dr.zeros(mi.Bool, n)
            for j in rows:
                sel |= t == j
            o, d, w = dr.select(sel, ol, o), dr.select(sel, dl, d), dr.select(sel, wl, w)
        return mi.Point3f(o + d * self.offset), d, w

    # ---- tracing
    def trace(self, n: int, seed: int, loop: str = "symbolic"):
        """Photons ``0 .. n-1`` of ``seed`` traced; returns (positions, powers) of those
        stored (evaluated), and the rays cast (lazy)."""
        mi, dr = self.mi, self.dr
        # The seed as an opaque variable: a Python int would be a literal in the kernel,
        # and each new seed a new kernel to compile.
        rng = mi.PCG32(size=n, initstate=dr.opaque(mi.UInt64, 0x9E3779B97F4A7C15 * (seed + 1) % 2**64))
        o, d, w = self.emit(rng)
        stored, sp, sw, rays = _trace(mi, dr, self, o, d, w, rng, loop)
        dr.eval(stored, sp, sw, rays)
        idx = dr.compress(stored)
        pos = dr.gather(mi.Point3f, sp, idx)
        pw = dr.gather(mi.Color3f, sw, idx)
        dr.eval(pos, pw)
        dr.sync_thread()
        return pos, pw, rays


def _trace_body(mi, dr, tr, o, d, w, rng, loop):
    """The bounce loop (``@dr.syntax`` turns the ``while`` into ``dr.while_loop``)."""
    scene = tr.mscene
    ray = mi.Ray3f(o, d)
    active = dr.any(w > 0.0)
    depth = mi.UInt32(0)
    rays = mi.UInt32(0)
    stored = mi.Bool(False)
    sp = dr.zeros(mi.Point3f, dr.width(active))
    sw = dr.zeros(mi.Color3f, dr.width(active))
    while dr.hint(active, mode=loop, compress=(loop == "evaluated")):
        rays += 1
        si = scene.ray_intersect(ray, active)
        hit = active & si.is_valid()
        sid = dr.reinterpret_array(mi.UInt32, si.shape)
        kind = dr.gather(mi.UInt32, tr.kind_t, sid, hit)
        dv = ray.d
        ng = mi.Vector3f(si.n)
        outer = dr.dot(dv, ng) < 0.0
        face = dr.select(outer, 1.0, -1.0)
        ng = ng * face  # both normals facing the photon
        ns = mi.Vector3f(si.sh_frame.n) * face
        # a diffuse receiver: store after >= 1 specular event, front face of a one-sided one
        back = (~outer) & (dr.gather(mi.UInt32, tr.one_sided_t, sid, hit) != 0)
        store = hit & (kind == DIFFUSE) & (depth > 0) & ~back
        stored |= store
        sp = dr.select(store, si.p, sp)
        sw = dr.select(store, w, sw)
        # a specular event
        spec = hit & (kind != DIFFUSE) & (depth < tr.max_bounces)
        glass = spec & (kind == GLASS)
        r = dv - 2.0 * dr.dot(dv, ns) * ns
        r = dr.select(dr.dot(r, ng) <= 0.0, dv - 2.0 * dr.dot(dv, ng) * ng, r)
        ior = dr.gather(mi.Float, tr.ior_t, sid, glass)
        eta = dr.select(outer, ior, 1.0 / ior)  # n_t / n_i
        cos_i = dr.clip(-dr.dot(dv, ns), 0.0, 1.0)
        F, cos_t, _, eta_ti = mi.fresnel(cos_i, eta)
        tdir = mi.refract(-dv, mi.Normal3f(ns), cos_t, eta_ti)
        # about the geometric normal where the shading one sends it out on the wrong side
        cos_g = dr.clip(-dr.dot(dv, ng), 0.0, 1.0)
        Fg, cos_tg, _, eta_tg = mi.fresnel(cos_g, eta)
        wrong = dr.dot(tdir, ng) >= 0.0
        tdir = dr.select(wrong, mi.refract(-dv, mi.Normal3f(ng), cos_tg, eta_tg), tdir)
        tir = dr.select(wrong, Fg >= 1.0, F >= 1.0)
        uc = rng.next_float32(glass)
        through = glass & (uc >= F) & ~tir
        nd = dr.normalize(dr.select(through, tdir, r))
        tint = dr.gather(mi.Color3f, tr.refl_t, sid, spec)  # reflectance or tint
        factor = dr.select(through | (spec & ~glass), tint, mi.Color3f(1.0))
        w = dr.select(spec, w * factor, w)
        spawned = si.spawn_ray(nd)
        ray = mi.Ray3f(dr.select(spec, spawned.o, ray.o), dr.select(spec, nd, ray.d))
        depth += dr.select(spec, 1, 0)
        active = spec & dr.any(w > 0.0)
    return stored, sp, sw, rays


_trace_fn = None


def _trace(mi, dr, tr, o, d, w, rng, loop):
    global _trace_fn
    if _trace_fn is None:
        _trace_fn = dr.syntax(_trace_body)
    return _trace_fn(mi, dr, tr, o, d, w, rng, loop)


def ptracer_runs(mi, dr, mscene, repeat: int, spp: int = 16) -> dict:
    """The peer on the same exported scene: Mitsuba's own particle tracer (the file's
    ``ptracer`` integrator) at the file's film size, ``spp`` light paths a pixel, its light
    paths a second (the median of ``repeat`` runs after one that compiles)."""
    w, h = (int(v) for v in mscene.sensors()[0].film().crop_size())
    times = []
    for r in range(repeat + 1):
        t = time.perf_counter()
        image = mi.render(mscene, spp=spp, seed=r)
        dr.eval(image)
        dr.sync_thread()
        times.append(time.perf_counter() - t)
    sec = statistics.median(times[1:])
    return {"size": [w, h], "spp": spp, "median_s": sec, "paths_per_s": spp * w * h / sec}


def drjit_runs(mi, dr, scene, photons: int, repeat: int, frac_hint: float, loop: str) -> dict:
    with tempfile.TemporaryDirectory(prefix="drjit-probe-") as tmp:
        tr = DrjitTracer(mi, dr, scene, Path(tmp))
        n = int(math.ceil(photons / max(frac_hint, 1e-6)))
        with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
            t = time.perf_counter()
            tr.trace(n, seed=1, loop=loop)
            cold = time.perf_counter() - t
            hist = dr.kernel_history()
        jit = [h for h in hist if h.get("type") == dr.KernelType.JIT]
        compile_ms = sum(float(h.get("codegen_time", 0)) + float(h.get("backend_time", 0))
                         for h in jit)
        times, outs = [], []
        for r in range(repeat):
            t = time.perf_counter()
            pos, pw, rays = tr.trace(n, seed=2 + r, loop=loop)
            times.append(time.perf_counter() - t)
            flux = [float(np.sum(np.asarray(pw[c], dtype=np.float64))) / n for c in range(3)]
            outs.append((dr.width(pos), flux, int(np.sum(np.asarray(rays, dtype=np.int64)))))
        sec = statistics.median(times)
        stored, flux, nrays = outs[times.index(sorted(times)[(len(times) - 1) // 2])]
        peer = ptracer_runs(mi, dr, tr.mscene, repeat)
        return {"ptracer": peer, "variant": mi.variant(), "loop": loop, "load_s": tr.load_s, "cold_s": cold,
                "cold_kernels": len(jit),
                "cold_kernels_from_cache": sum(bool(h.get("cache_hit") or h.get("cache_disk"))
                                               for h in jit),
                "cold_compile_s": compile_ms / 1e3, "warm_s": times, "median_s": sec,
                "stored": stored, "emitted": n, "stored_per_s": stored / sec,
                "emitted_per_s": n / sec, "stored_per_emitted": stored / n, "rays_cast": nrays,
                "flux": [float(x) for x in flux]}


def main(argv=None) -> int:
    p = ToolParser(__doc__, __file__)
    p.scenes("ring,sun,cbox")
    p.add_argument("--photons", type=count, default=1_000_000,
                   help="stored photons each run aims at (default 1,000,000)")
    p.add_argument("--repeat", type=count, default=3, help="warm runs, median kept (default 3)")
    p.add_argument("--loop", choices=("symbolic", "evaluated"), default="symbolic",
                   help="Dr.Jit loop mode: one kernel with the loop inside, or a kernel per "
                        "bounce with the live lanes compressed (default symbolic)")
    p.json_output()
    args = p.parse_args(argv)

    from blockhash.reference.mitsuba import load_mitsuba_module

    mi, variant = load_mitsuba_module()
    if not variant.startswith(("llvm", "cuda")):
        raise SystemExit(f"Mitsuba's {variant} is not a JIT variant; the probe needs llvm_* or cuda_*")
    import drjit as dr

    rows = []
    for path in args.scenes:
        scene = load_scene(path)
        bh = blockhash_runs(scene, args.photons, args.repeat)
        dj = drjit_runs(mi, dr, scene, args.photons, args.repeat, bh["stored_per_emitted"], args.loop)
        rows.append({"scene": path.stem, "photons": args.photons, "repeat": args.repeat,
                     "max_bounces": int(scene.photons.max_bounces), "blockhash": bh, "drjit": dj,
                     "ratio": dj["stored_per_s"] / bh["stored_per_s"]})
        print(f"{path.stem}: blockhash {bh['stored_per_s']:,.0f}/s, Dr.Jit {dj['stored_per_s']:,.0f}/s "
              f"(cold {dj['cold_s']:.2f} s, compile {dj['cold_compile_s']:.2f} s)", file=sys.stderr)

    print(f"\nCaustic photons, {args.photons:,} stored target, median of {args.repeat} warm runs "
          f"(Dr.Jit {rows[0]['drjit']['variant'] if rows else variant}, {args.loop} loop)\n")
    print("| scene | blockhash stored/s | Dr.Jit llvm stored/s | ratio | stored/emitted "
          "(blockhash / Dr.Jit) | Dr.Jit cold s |")
    print("|---|---:|---:|---:|---|---:|")
    for r in rows:
        bh, dj = r["blockhash"], r["drjit"]
        print(f"| {r['scene']} | {bh['stored_per_s']:,.0f} | {dj['stored_per_s']:,.0f} | "
              f"{r['ratio']:.2f} | {bh['stored_per_emitted']:.3f} / {dj['stored_per_emitted']:.3f} | "
              f"{dj['cold_s']:.2f} |")
    print("\n| scene | flux blockhash W | flux Dr.Jit W | emitted/s blockhash | emitted/s Dr.Jit "
          "| Mitsuba ptracer light paths/s |")
    print("|---|---|---|---:|---:|---:|")
    for r in rows:
        bh, dj = r["blockhash"], r["drjit"]
        fb = ", ".join(f"{x:.4g}" for x in bh["flux"])
        fd = ", ".join(f"{x:.4g}" for x in dj["flux"])
        print(f"| {r['scene']} | {fb} | {fd} | {bh['emitted_per_s']:,.0f} | {dj['emitted_per_s']:,.0f} "
              f"| {dj['ptracer']['paths_per_s']:,.0f} |")
    if args.json:
        write_json(args.json, {"rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
