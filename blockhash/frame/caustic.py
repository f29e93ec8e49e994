"""Caustic radiance from a Block Hashing photon map: shader pass and CPU reference.

The estimate (glsl/caustic_estimate.glsl) at a shading point with normal n and
viewer direction wo is ``L = sum w f_r(wi, wo) Phi_p / (pi r^2)`` over the found
photons that arrive from the front (``dot(-d_p, n) > 0``) and pass the tests of
:class:`~.estimate.EstimateOptions` (the photon's stored surface normal, the
flattened neighbourhood, the unbiased form leaving out the farthest), with r the
distance to the farthest photon found (the k-th when k were found), w the filter
weight and f_r the modified Phong BRDF (Lafortune & Willems 1994); the conserving
estimate puts each photon's own radius (:mod:`.photon_radius`) in place of r.  Shading points
come as per-pixel arrays (position, normal, viewer direction, material id, path
weight), so mirrors seen by the camera are handled upstream by moving the shading
point to what the mirror reflects.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from blockhash.errors import InputError
from blockhash.frame.estimate import EstimateOptions, photon_weights
from blockhash.frame.photon_radius import exact_radii2, own_radii2
from blockhash.frame.shading_points import ShadingPoints
from blockhash.gl.context import (
    bind_textures,
    check_gl,
    draw_timed,
    get_context,
    home_framebuffer,
    time_draws,
)
from blockhash.gl.limits import check_lookup
from blockhash.gl.lookup import GLLookup, query_slot_bits
from blockhash.gl.pool import give_back, pooled_texture
from blockhash.gl.shaderlib import Variant
from blockhash.index.records.codec import decode_directions, decode_powers, unpack_records
from blockhash.index.records.fixedpoint import min_r2
from blockhash.scene.materials import material_arrays, phong_brdf

#: Materials a caustic pass can hold (uniform arrays in caustic_pass.frag).
MAX_MATERIALS = 16
#: How a caustic pass finds photons: the k nearest (the index's lookup) or the cover gather.
GATHERS = ("knn", "cover")
#: caustic_pass.frag's CP_GATHER for each gather it compiles (the k nearest's cells lookup
#: is its own).
CP_GATHER = {"cover": 1, "cells": 2, "knn": 3}


def estimate_cpu(index, points: ShadingPoints, materials, *, k=None, A=None,
                 variant: str = "default", options: EstimateOptions | None = None,
                 radii=None) -> np.ndarray:
    """The CPU reference of the caustic pass: (h, w, 3) float64 radiance.

    Uses :meth:`BlockHashIndex.query` in the mode of ``variant`` so that it finds the
    same photons as the shader; ``options`` and ``radii`` as :class:`CausticPass` takes them.
    """
    v = Variant.parse(variant)
    prm = index.params
    k = prm.k if k is None else k
    bits = query_slot_bits(prm, k, prm.A if A is None else A) if v.packed_keys else 0

    def search(q):
        return index.reference_query(q, k=k, A=A, by_priority=v.priority == "on", slot_bits=bits)

    return estimate_from_neighbours(index, points, materials, search, k, options=options,
                                    radii=radii)


def estimate_exact(index, points: ShadingPoints, materials, *, k=None, backend=None,
                   gpu: bool = True, options: EstimateOptions | None = None,
                   radii=exact_radii2) -> np.ndarray:
    """The caustic with the exact k nearest photons: the kd-tree shader (``gpu``) or cKDTree;
    ``radii(index, k)`` the conserving estimate's (default :func:`.photon_radius.exact_radii2`)."""
    k = index.params.k if k is None else k
    if gpu:
        from blockhash.gl.kdtree import GLKdTree

        tree = GLKdTree(index.positions, backend=backend)
        try:
            return estimate_from_neighbours(index, points, materials, lambda q: tree.query(q, k),
                                            k, options=options, radii=radii)
        finally:
            tree.release()
    from blockhash.index.lookups.exact import exact_knn

    return estimate_from_neighbours(index, points, materials,
                                    lambda q: exact_knn(index.positions, q, k), k, options=options,
                                    radii=radii)


def estimate_from_neighbours(index, points: ShadingPoints, materials, search, k, *,
                             options: EstimateOptions | None = None, radii=None) -> np.ndarray:
    """The density estimate of the module docstring with neighbours from ``search(q)``.

    ``search`` maps (m, 3) float32 points to cKDTree-style ``(distances, indices)``;
    ``radii(index, k)`` the photons' own squared radii of the conserving estimate
    (default :func:`.photon_radius.own_radii2`, the octree search; the exact
    estimate passes :func:`.photon_radius.exact_radii2`).
    """
    options = EstimateOptions() if options is None else options
    return Neighbours.find(index, points, search, k, own=[options],
                           radii=radii).estimate(materials, options)


@dataclass(frozen=True)
class Neighbours:
    """The photons found for every live pixel, decoded once, so that several estimate
    options can be evaluated on the same search (q live pixels, k slots each)."""

    points: ShadingPoints
    live: np.ndarray        # (h * w,) bool
    d2: np.ndarray          # (q, k) float64 squared distances
    found: np.ndarray       # (q, k) bool
    r2: np.ndarray          # (q,) float64 squared radius (0 where none was found)
    wi: np.ndarray          # (q, k, 3) float64 toward where each photon came from
    normal: np.ndarray      # (q, k, 3) float64 the photon's stored surface normal
    offset: np.ndarray      # (q, k, 3) float64 photon position minus the shading point
    power: np.ndarray       # (q, k, 3) float64 watts
    own_r2: np.ndarray | None = None  # (q, k) float64 each photon's own squared radius

    @classmethod
    def find(cls, index, points: ShadingPoints, search, k, *, own=(), radii=None) -> "Neighbours":
        """The neighbours of ``points``; ``own``: the options that will be estimated (the
        photons' own radii, ``radii(index, k)``, default :func:`.photon_radius.own_radii2`,
        are looked up when one of them is the conserving estimate)."""
        mat = points.material.reshape(-1)
        live = mat >= 0
        q = points.position.reshape(-1, 3)[live]
        nq = len(q)
        if nq:
            d, idx = search(q)
            d, idx = np.asarray(d).reshape(nq, k), np.asarray(idx).reshape(nq, k)
        else:
            d, idx = np.zeros((0, k)), np.zeros((0, k), np.int64)
        found = idx < len(index)
        safe = np.where(found, index.slot_of[np.minimum(idx, len(index) - 1)], 0).ravel()
        rec = index.records.records[safe]
        pcodes, dcodes, ncodes, pbits = unpack_records(rec)
        wi = -decode_directions(dcodes).astype(np.float64).reshape(nq, k, 3)
        normal = decode_directions(ncodes).astype(np.float64).reshape(nq, k, 3)
        pos = index.records.quantizer.decode(pcodes).astype(np.float64).reshape(nq, k, 3)
        power = decode_powers(pbits, index.records.power_scale)[:, :3].astype(np.float64)
        d2 = np.where(found, d.astype(np.float64) ** 2, np.inf)
        last = np.where(found.any(axis=1), found.sum(axis=1) - 1, 0)
        r2 = np.where(found.any(axis=1), np.maximum(d2[np.arange(nq), last], min_r2(index)), 0.0)
        own_r2 = None
        if any(o.conserving for o in own):
            per_photon = (radii or own_radii2)(index, k)
            own_r2 = np.where(found, per_photon[np.where(found, idx, 0)], np.inf)
        return cls(points, live, d2, found, r2, wi, normal,
                   pos - q.astype(np.float64)[:, None, :], power.reshape(nq, k, 3), own_r2)

    def estimate(self, materials, options: EstimateOptions | None = None) -> np.ndarray:
        """(h, w, 3) float64 radiance with ``options`` (None: the defaults)."""
        options = EstimateOptions() if options is None else options
        pts = self.points
        h, w = pts.shape
        out = np.zeros((h * w, 3))
        nq, k = self.found.shape
        if not nq:
            return out.reshape(h, w, 3)
        n = pts.normal.reshape(-1, 3)[self.live].astype(np.float64)
        wo = pts.view.reshape(-1, 3)[self.live].astype(np.float64)
        weight = photon_weights(options, self.d2, self.r2, self.found, self.wi, self.normal, n,
                                self.offset, self.own_r2)
        table = material_table(materials)
        mid = np.repeat(pts.material.reshape(-1)[self.live], k)
        f = phong_brdf(self.wi.reshape(-1, 3), np.repeat(wo, k, axis=0), np.repeat(n, k, axis=0),
                       table[0][mid], table[1][mid], table[2][mid])
        contrib = (weight.reshape(-1, 1) * f * self.power.reshape(-1, 3)).reshape(nq, k, 3).sum(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            L = np.where(self.r2[:, None] > 0, contrib / (np.pi * self.r2[:, None]), 0.0)
        out[self.live] = L * pts.weight.reshape(-1, 3)[self.live]
        return out.reshape(h, w, 3)


def point_textures(ctx, points: ShadingPoints) -> list:
    """The shading points as the passes read them, three RGBA32F textures, bottom row first
    (GL's): cp_position (xyz, material id), cp_normal (xyz, 1), cp_view (xyz, 0)."""
    h, w = points.shape
    out = []
    for role, xyz, fourth in (("cp_position", points.position, points.material[::-1]),
                              ("cp_normal", points.normal, 1.0), ("cp_view", points.view, 0.0)):
        rgba = np.empty((h, w, 4), np.float32)  # written once, rows flipped on the way in
        rgba[..., :3] = xyz[::-1]
        rgba[..., 3] = fourth
        tex = pooled_texture(ctx, role, w, h, 4, "f4", exact=True)
        tex.write(rgba, viewport=(0, 0, w, h))
        out.append(tex)
    return out


def material_table(materials):
    """[(kd, ks, exponent)] -> (kd (M,3), ks (M,3), e (M,)) float64, within the pass's uniforms."""
    if len(materials) > MAX_MATERIALS:
        raise InputError(f"{len(materials)} receiver materials > {MAX_MATERIALS} that the caustic "
                         "pass holds; merge materials")
    return material_arrays(materials)


#: Stages of the caustic pass that ``CausticPass.time_stages`` times, each a program of
#: caustic_pass.frag: the lookup's fetches alone (BH_FETCH_ONLY, the memory floor), the
#: lookup with selection (CP_LOOKUP_ONLY), and the whole pass with the estimate.
STAGES = ("fetch floor", "lookup", "lookup + estimate")


class CausticPass:
    """The caustic pass in a fragment shader over an uploaded index (GLLookup's textures).

    After :meth:`render`, ``seconds`` is the draw's wall time and ``gpu_seconds`` its
    GL timer-query time.
    """

    def __init__(self, index, *, backend=None, radii=None, gather: str = "knn"):
        """``radii(index, k)``: the photons' own squared radii of the conserving estimate
        (default :func:`.photon_radius.own_radii2`, the octree search).  ``gather``:
        ``'knn'`` finds the k nearest photons with the index's lookup (every estimate);
        ``'cover'`` every photon whose own disc covers the point (the conserving estimate,
        :mod:`blockhash.index.lookups.cover`), and uploads no blocks."""
        if gather not in GATHERS:
            raise InputError(f"gather={gather!r} is not known; choose one of {', '.join(GATHERS)}")
        self.radii = radii
        self.gather = gather
        self.backend = backend
        self.lookup = GLLookup(index, backend=backend) if gather == "knn" else None
        self.index = index
        self.ctx = get_context(backend)
        self._covers: dict = {}  # k -> GLCover
        self.seconds = 0.0
        self.gpu_seconds = 0.0
        self._own: dict = {}  # k -> (texture of the photons' own squared radii, log2 width)

    def render(self, points: ShadingPoints, materials, *, k=None, A=None,
               variant: str = "default", options: EstimateOptions | None = None) -> np.ndarray:
        """(h, w, 3) float32 caustic radiance, row 0 at the top like ``points``.

        ``options`` : :class:`~.estimate.EstimateOptions` (None: the defaults), the same
        that :func:`estimate_cpu` takes.
        """
        with self._pass(points, materials, k, A, variant, STAGES[-1], options) as (prog, fbo, out_tex):
            self.seconds, self.gpu_seconds = draw_timed(self.ctx, prog, fbo, points.shape[::-1])
            check_gl(self.ctx, "the caustic pass draw")
            h, w = points.shape
            img = np.frombuffer(out_tex.read(), dtype=np.float32).reshape(h, w, 4)[::-1, :, :3]
        return np.ascontiguousarray(img * points.weight)

    def time_stages(self, points: ShadingPoints, materials, *, k=None, A=None,
                    variant: str = "default", repeat: int = 10, warmup: int = 2,
                    options: EstimateOptions | None = None, stages=STAGES) -> dict:
        """GPU and wall time of each of ``stages`` (of :data:`STAGES`): ``{stage: {'wall':
        [...], 'gpu': [...]}}``, seconds per draw, ``repeat`` back-to-back draws after
        ``warmup`` draws of the same program (:func:`blockhash.gl.context.time_draws`)."""
        unknown = [s for s in stages if s not in STAGES]
        if unknown:
            raise InputError(f"stages {unknown} are not stages of the caustic pass; choose from "
                             f"{', '.join(STAGES)}")
        out = {}
        for stage in stages:
            with self._pass(points, materials, k, A, variant, stage, options) as (prog, fbo, _):
                walls, gpus = time_draws(self.ctx, prog, fbo, points.shape[::-1],
                                         repeat=repeat, warmup=warmup)
                check_gl(self.ctx, f"the timed caustic pass draws ({stage})")
            out[stage] = {"wall": walls, "gpu": gpus}
        return out

    def release(self) -> None:
        """Release the pass's GL objects (the index's textures, its gathers and radii); the
        programs stay in :mod:`blockhash.gl.shaderlib`'s cache."""
        with self.ctx:
            for cover in self._covers.values():
                cover.release()
            for tex, _ in self._own.values():
                give_back(tex)
        self._covers.clear()
        self._own.clear()
        if self.lookup is not None:
            self.lookup.release()
            self.lookup = None

    def _cover(self, k: int):
        """The cover gather for k neighbours' radii, uploaded once."""
        from blockhash.frame.cover_estimate import cover_gather
        from blockhash.gl.cover import GLCover

        if k not in self._covers:
            self._covers[k] = GLCover(cover_gather(self.index, k, self.radii), backend=self.backend)
        return self._covers[k]

    def _own_radii(self, k: int):
        """The texture of the photons' own squared radii for k neighbours, uploaded once."""
        from blockhash.frame.photon_radius import slot_radii2
        from blockhash.gl.packing import upload

        if k not in self._own:
            with self.ctx:
                self._own[k] = upload(self.ctx, slot_radii2(self.index, k, self.radii), 1,
                                      "photon radius", dtype="f4", pooled=True)
        return self._own[k]

    @contextmanager
    def _pass(self, points: ShadingPoints, materials, k, A, variant, stage, options=None):
        """The program of ``stage`` with its inputs bound, and the output framebuffer."""
        from blockhash.gl.shaderlib import compile_program

        prm = self.index.params
        k = prm.k if k is None else k
        A = prm.A if A is None else A
        h, w = points.shape
        kd, ks, e = material_table(materials)
        ctx = self.ctx
        options = EstimateOptions() if options is None else options
        own = {}
        if self.gather == "cover":
            from blockhash.frame.cover_estimate import require_conserving

            require_conserving(options)
            source = self._cover(k)
            source.check()
            defines = source.defines(fetch_only=stage == STAGES[0])
        else:
            source = self.lookup
            check_lookup(ctx, prm, Variant.parse(variant), k, A)
            defines = self.lookup.defines(Variant.parse(variant), k, self.lookup.cap(k, A),
                                          fetch_only=stage == STAGES[0])
            if options.conserving:
                own_tex, defines["CAUSTIC_OWN_W"] = self._own_radii(k)
                own = {"caustic_own_r2": own_tex}
        gather = (CP_GATHER["cover"] if self.gather == "cover"
                  else CP_GATHER["cells"] if defines.get("BH_CELLS") else CP_GATHER["knn"])
        defines = {**defines, "CP_GATHER": gather, "CP_LOOKUP_ONLY": int(stage != STAGES[-1]),
                   **options.defines()}
        with ctx:
            prog = compile_program(ctx, "caustic_pass.frag", defines)
            # Textures are bottom-up in GL: flip rows on the way in and out.
            texs = point_textures(ctx, points)
            out_tex = pooled_texture(ctx, "caustic pass output", w, h, 4, "f4", exact=True)
            fbo = ctx.framebuffer(color_attachments=[out_tex])
            try:
                check_gl(ctx, f"allocating the {w} x {h} caustic pass")
                source.set_uniforms(prog)
                for name, value in (("caustic_min_r2", min_r2(self.index)),
                                    *options.uniforms().items()):
                    if name in prog:  # the lookup-only stages estimate nothing
                        prog[name].value = value
                pad = MAX_MATERIALS - len(kd)
                for name, value in (("cp_kd", [tuple(r) for r in np.vstack([kd, np.zeros((pad, 3))])]),
                                    ("cp_ks", [tuple(r) for r in np.vstack([ks, np.zeros((pad, 3))])]),
                                    ("cp_exponent", [float(x) for x in np.concatenate([e, np.zeros(pad)])])):
                    if name in prog:  # the lookup-only stages use no material
                        prog[name].value = value
                bind_textures(prog, {**source.textures(), "cp_position": texs[0],
                                     "cp_normal": texs[1], "cp_view": texs[2], **own})
                yield prog, fbo, out_tex
            finally:
                home_framebuffer(ctx).use()
                for obj in (*texs, fbo, out_tex):
                    give_back(obj)
