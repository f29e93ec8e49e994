"""The trade study (paper section 6, extended): every setting timed and measured in one run.

For one scene and image size it

1. light-traces the unbiased reference of the caustic layer once (cached by scene
   content, :func:`blockhash.reference.lighttrace.cached_reference`);
2. rasterises the shading points once (the G-buffer does not depend on the photons);
3. for each photon count N traces a photon map (timed), and for each k computes the
   exact-kNN caustic of that map with scipy's cKDTree (and, at the largest N, the
   exact kd-tree shader), both timed;
4. for each setting (N, k, A, preset, variant) of :class:`SweepPlan` builds the
   index (timed), runs the caustic pass in GL (compiled by a warm-up draw first, then
   timed: wall time of the pass, and the draw alone), and measures its image against
   the exact one and the reference (:mod:`blockhash.studies.measure`), and its neighbours against the
   exact ones (false negatives and dilations per pixel query, paper Figs. 12 and 14;
   :mod:`blockhash.evaluate.metrics`).

The result is a dict (written as ``tradeoff.json`` by :mod:`blockhash.studies.tradeoff.report`): ``rows`` holds
one dict per setting with at least ``method``, ``photons``, ``k``, ``A``, ``preset``,
``variant``, ``seconds`` (per stage), ``rel_rms_exact``, ``rel_rms_reference`` and
``flux_ratio_reference``; exact rows have ``method`` 'exact-ckdtree' or
'exact-kdtree-shader' and ``A = preset = variant = None``; the cover gather's rows (the default
render's gather) ``method`` 'cover', ``A = preset = variant = None`` and ``spp``.
"""

from __future__ import annotations

import platform
import time
from dataclasses import dataclass, replace

import numpy as np

from blockhash import __version__
from blockhash.errors import InputError
from blockhash.evaluate.metrics import accuracy, exact_knn
from blockhash.frame.caustic import CausticPass, estimate_cpu, estimate_exact
from blockhash.frame.gbuffer import rasterize
from blockhash.frame.scene_rays import SceneRays
from blockhash.frame.shading import shading_points
from blockhash.index.block_hash_index import BlockHashIndex
from blockhash.index.tables.params import PRESETS
from blockhash.photons.tracing import trace_caustic_photons
from blockhash.reference.lighttrace import cached_reference, scene_digest
from blockhash.scene.materials import receiver_materials
from blockhash.scene.model import MirrorMaterial
from blockhash.studies.measure import errors_against

#: How the caustic layer of a setting is computed: 'gl' the caustic pass shader (timed
#: draws), 'cpu' its CPU reference (the same neighbours, tests/frame/test_caustic.py; no shader
#: compiles, so small studies and tests run in seconds, but times are CPU times).
ENGINES = ("gl", "cpu")


@dataclass(frozen=True)
class SweepPlan:
    """Which settings a trade study runs.

    photons : N values (at least two, sorted); k0, A0 the base k and A.
    grid_A : A values run with k0 at every N of ``grid_photons`` (default: every N).
    ks : k values run at every N with A0 (variance against blur).
    presets : index presets run at the largest N over ``preset_A``.
    variants : shader variants run at the largest N, k0, A0.
    size : (width, height) of the images; reference_photons : photons of the reference.
    supersample : the caustic layers are rendered at ``supersample`` times ``size`` and
        box-filtered down, so that their pixels, like the reference's, are pixel-area
        means (one sample at the pixel centre differs from the mean wherever the caustic
        has detail inside a pixel, and that would count as error).
    engine : {'gl', 'cpu'}, see ENGINES.
    cover : also run the cover gather (the default render's gather; its knobs are N and k,
        so the disc's photon count j, not A) once per (N, k), beside the k-nearest rows.
    cover_supersamples : further supersampling factors s (s * s samples per pixel) of the
        cover gather at the largest N and k0: its spp knob.
    """

    photons: tuple = (10_000, 30_000, 100_000, 300_000, 1_000_000)
    k0: int = 50
    A0: int = 8
    grid_A: tuple = (1, 2, 4, 8, 16, 32, 64)
    grid_photons: tuple | None = None
    ks: tuple = (16, 32, 50, 100)
    presets: tuple = ("default", "paper")
    preset_A: tuple = (1, 2, 4, 8, 16, 32, 64)
    variants: tuple = ("default", "paper", "binary-branch-on-network", "linear-branch-on-packed",
                       "binary-zero-on-packed", "binary-branch-off-packed")
    size: tuple = (128, 128)
    reference_photons: int = 50_000_000
    kdtree_shader: bool = True
    engine: str = "gl"
    supersample: int = 2
    cover: bool = True
    cover_supersamples: tuple = (1, 3)

    def settings(self):
        """(N, k, A, preset, variant) tuples, each once, in run order."""
        out = []
        grid = self.photons if self.grid_photons is None else self.grid_photons
        for n in self.photons:
            out += [(n, k, self.A0, "default", "default") for k in self.ks]
            if n in grid:
                out += [(n, self.k0, a, "default", "default") for a in self.grid_A]
        top = max(self.photons)
        out += [(top, self.k0, a, p, "default") for p in self.presets for a in self.preset_A]
        out += [(top, self.k0, self.A0, "default", v) for v in self.variants]
        seen, ordered = set(), []
        for s in out:
            if s not in seen and s[1] <= s[0]:
                seen.add(s)
                ordered.append(s)
        return ordered

    def __post_init__(self):
        if self.engine not in ENGINES:
            raise InputError(f"engine={self.engine!r} is not known; choose one of {', '.join(ENGINES)}")
        if len(self.photons) < 2:
            raise InputError(f"photons={self.photons!r}: give at least two photon counts")
        for p in self.presets:
            if p not in PRESETS:
                raise InputError(f"preset {p!r} is not known; choose from {', '.join(PRESETS)}")
        object.__setattr__(self, "photons", tuple(sorted(int(n) for n in self.photons)))
        if self.grid_photons is not None:  # keep the grid on measured N values
            grid = tuple(n for n in self.grid_photons if n in self.photons)
            object.__setattr__(self, "grid_photons", grid or (max(self.photons),))


#: About a minute on two slow cores with llvmpipe, most of it shader compiles (~4 s per
#: program there: every N, k, A and preset gives its own #defines).
QUICK = SweepPlan(photons=(1_000, 3_000, 10_000, 30_000, 100_000), grid_A=(1, 2, 4, 8, 16, 64),
                  grid_photons=(100_000,), ks=(50,), preset_A=(8,), variants=("default",),
                  size=(48, 48), reference_photons=4_000_000, kdtree_shader=False)


def machine_info(ctx=None) -> dict:
    import moderngl
    import scipy

    info = {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
            "cpus": __import__("os").cpu_count(), "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "moderngl": moderngl.__version__,
            "blockhash": __version__}
    if ctx is not None:
        info["gl_renderer"] = ctx.info.get("GL_RENDERER")
        info["gl_version"] = ctx.info.get("GL_VERSION")
    return info


#: Timed draws per setting (after the warm-up); the minimum is kept.
REPEAT = 3


def _timed_pass(cp: CausticPass, points, materials, variant):
    """(image, seconds dict) of one caustic pass after a warm-up draw that compiles it.

    The warm-up draws the full image: llvmpipe compiles again for other texture sizes.
    Times are the minimum of ``REPEAT`` passes; ``gl_timer`` the GL timer query of the last."""
    cp.render(points, materials, variant=variant)
    timer = None
    try:
        timer = cp.ctx.query(time=True)
    except Exception:  # noqa: BLE001 - moderngl raises its own Error where queries are missing
        timer = None
    walls, draws = [], []
    for _ in range(REPEAT):
        t = time.perf_counter()
        if timer is not None:
            with timer:
                img = cp.render(points, materials, variant=variant)
        else:
            img = cp.render(points, materials, variant=variant)
        walls.append(time.perf_counter() - t)
        draws.append(cp.seconds)
    sec = {"caustic_pass": min(walls), "gl_draw": min(draws)}
    try:
        sec["gl_timer"] = timer.elapsed * 1e-9 if timer is not None else None
    except Exception:  # noqa: BLE001 - "query created without the time_elapsed flag" on some stacks
        sec["gl_timer"] = None
    return img, sec


def run_sweep(scene, plan: SweepPlan = QUICK, *, seed=None, cache_dir=None, backend=None,
              progress=print) -> dict:
    """Run ``plan`` on ``scene`` and return the study as a dict (see the module docstring)."""
    from blockhash.gl.context import get_context
    from blockhash.gl.lookup import query_slot_bits
    from blockhash.gl.shaderlib import Variant

    if not scene.specular_objects:
        raise InputError(f"scene {scene.path}: no specular (mirror) object, so no caustic to "
                         "study; add a mirror or study another scene")
    seed = scene.photons.seed if seed is None else seed
    size = tuple(plan.size)
    t0 = time.perf_counter()
    ref, ref_path = cached_reference(scene, plan.reference_photons, size=size, cache_dir=cache_dir,
                                     progress=False)
    progress(f"reference: {ref!r} ({'cached ' + str(ref_path) if ref_path else 'not cached'}, "
             f"{time.perf_counter() - t0:.1f} s)")
    mask_ref = ref.comparison_mask()
    rel_noise = float(np.sqrt(np.mean(ref.stderr[mask_ref] ** 2))
                      / np.sqrt(np.mean(ref.radiance[mask_ref] ** 2)))
    ss = int(plan.supersample)
    g = rasterize(scene.camera, scene.objects, size=(size[0] * ss, size[1] * ss), backend=backend)
    points = shading_points(scene.camera, g, scene.objects, SceneRays(scene.objects), (MirrorMaterial,))
    fine_live = points.material >= 0
    live = box_down(fine_live, ss) == 1.0
    queries = points.position[fine_live].astype(np.float32)
    materials = receiver_materials(scene.objects)
    ctx = get_context(backend)
    rows, images = [], {"reference": ref.radiance, "mask": mask_ref}
    settings = plan.settings()
    maps, exact, knn = {}, {}, {}
    for i, (n, k, A, preset, variant) in enumerate(settings):
        if n not in maps:
            t = time.perf_counter()
            maps[n] = trace_caustic_photons(scene, n, seed=seed)
            maps[n] = (maps[n], time.perf_counter() - t)
        photons, t_trace = maps[n]
        t = time.perf_counter()
        index = BlockHashIndex(photons.positions, k=k, A=A, preset=preset,
                               directions=photons.directions, normals=photons.normals,
                               powers=photons.powers)
        t_index = time.perf_counter() - t
        if (n, k) not in exact:
            exact[(n, k)] = _exact_rows(index, points, materials, n, k, t_trace, ref, mask_ref, ss,
                                        rows, backend, plan.kdtree_shader and n == max(plan.photons)
                                        and k == plan.k0)
            ckd_row = next(r for r in rows[::-1] if r["method"] == "exact-ckdtree")
            t = time.perf_counter()
            knn[(n, k)] = exact_knn(index.positions, queries, k)
            ckd_row["seconds"]["search"] = time.perf_counter() - t  # the cKDTree search alone
            if plan.cover:
                rows += _cover_rows(plan, scene, index, points, materials, ss, n, k, photons,
                                    t_trace, exact[(n, k)], live, ref, mask_ref, backend, progress)
        # (the fine image is box-filtered to the study's size below)
        if plan.engine == "gl":
            cp = CausticPass(index, backend=backend)
            img, sec = _timed_pass(cp, points, materials, variant)
            cp.lookup.release()
        else:
            t = time.perf_counter()
            img = estimate_cpu(index, points, materials, variant=variant)
            sec = {"caustic_pass": time.perf_counter() - t, "gl_draw": None, "gl_timer": None}
        img = box_down(img, ss)
        v = Variant.parse(variant)
        approx = index.reference_query(queries, k=k, A=A, by_priority=v.priority == "on",
                             slot_bits=query_slot_bits(index.params, k, A)
                             if v.select == "packed" else 0)
        acc = accuracy(approx, knn[(n, k)], len(index))
        row = {"method": "bh", "photons": n, "emitted": photons.emitted, "k": k, "A": A,
               "preset": preset, "variant": variant,
               "seconds": {"trace": t_trace, "index_build": t_index, **sec},
               "candidates": float(index.counters.get("query.candidates.mean", np.nan)),
               "L": index.params.L, "B": index.params.B,
               **errors_against(img, exact[(n, k)], live, "exact"),
               **errors_against(img, ref.radiance, mask_ref, "reference"),
               "false_negatives": acc.fn_fraction, "max_dilation": acc.max_dilation["mean"],
               "avg_dilation": acc.avg_dilation["mean"]}
        rows.append(row)
        if n == max(plan.photons) and k == plan.k0 and preset == "default" and variant == "default":
            images[f"A{A}"] = img
        progress(f"[{i + 1}/{len(settings)}] N={n:,} k={k} A={A} {preset}/{variant}: "
                 f"err exact {row['rel_rms_exact']:.3f}, ref {row['rel_rms_reference']:.3f}, "
                 f"flux {row['flux_ratio_reference']:.3f}, blur {row['rel_rms_reference_blur']:.3f}, FN {row['false_negatives']:.1%}, "
                 f"pass {sec['caustic_pass']:.3f} s")
    images["exact"] = exact[(max(plan.photons), plan.k0)]
    notes = []
    if not any("flip_reference" in r for r in rows):
        notes.append("FLIP not computed: the package flip-evaluator is not installed "
                     "(pip install flip-evaluator)")
    if plan.engine == "cpu":
        notes.append("engine 'cpu': images from the CPU reference of the caustic pass (the same "
                     "neighbours as the shader); caustic_pass times are CPU times")
    elif all(r["seconds"].get("gl_timer") is None for r in rows if r["method"] == "bh"):
        notes.append("GL timer queries gave no result on this context; gl_draw is the drained "
                     "wall time of the draw alone")
    return {
        "scene": str(scene.path), "scene_digest": scene_digest(scene), "size": list(size),
        "seed": seed, "plan": {k: (list(v) if isinstance(v, tuple) else v)
                               for k, v in plan.__dict__.items()},
        "machine": machine_info(ctx),
        "reference": {"photons": ref.emitted, "seed": ref.stats.get("seed"),
                      "cache": str(ref_path) if ref_path else None,
                      "pixels_compared": int(mask_ref.sum()), "rel_noise": rel_noise,
                      "seconds": ref.stats.get("seconds")},
        "rows": rows, "notes": notes, "seconds_total": time.perf_counter() - t0,
        "_images": images,
    }


def _cover_image(plan, index, points, materials, k, backend):
    """(image, seconds) of the cover gather's caustic on ``points``: its pass (engine 'gl')
    or its CPU reference; the gather's build (radii, cells) outside the timing."""
    from blockhash.frame.cover_estimate import cover_gather, estimate_cover_cpu

    t = time.perf_counter()
    gather = cover_gather(index, k)
    t_gather = time.perf_counter() - t
    if plan.engine == "gl":
        img, sec = _timed_pass(CausticPass(index, backend=backend, gather="cover"), points,
                               materials, "default")
    else:
        t = time.perf_counter()
        img = estimate_cover_cpu(gather, points, materials)
        sec = {"caustic_pass": time.perf_counter() - t, "gl_draw": None, "gl_timer": None}
    return img, {"cover_gather": t_gather, **sec}


def _cover_rows(plan, scene, index, points, materials, ss, n, k, photons, t_trace, exact_img,
                live, ref, mask_ref, backend, progress) -> list[dict]:
    """The cover gather's rows of (n, k): at the study's supersampling, and at the largest N
    and k0 also at each of ``plan.cover_supersamples``."""
    factors = [ss]
    if n == max(plan.photons) and k == plan.k0:
        factors += [f for f in plan.cover_supersamples if f != ss]
    out = []
    for f in factors:
        pts = points
        if f != ss:
            size = tuple(plan.size)
            g = rasterize(scene.camera, scene.objects, size=(size[0] * f, size[1] * f),
                          backend=backend)
            pts = shading_points(scene.camera, g, scene.objects, SceneRays(scene.objects),
                                 (MirrorMaterial,))
        img, sec = _cover_image(plan, index, pts, materials, k, backend)
        img = box_down(img, f)
        row = {"method": "cover", "photons": n, "emitted": photons.emitted, "k": k, "A": None,
               "preset": None, "variant": None, "spp": f * f,
               "seconds": {"trace": t_trace, **sec},
               **errors_against(img, exact_img, live, "exact"),
               **errors_against(img, ref.radiance, mask_ref, "reference")}
        out.append(row)
        progress(f"cover N={n:,} k={k} spp={f * f}: err ref {row['rel_rms_reference']:.3f}, "
                 f"flux {row['flux_ratio_reference']:.3f}, blur {row['rel_rms_reference_blur']:.3f}, "
                 f"pass {sec['caustic_pass']:.3f} s")
    return out


def box_down(image, s: int) -> np.ndarray:
    """Mean over s x s blocks: (h*s, w*s[, c]) -> (h, w[, c]) float64."""
    a = np.asarray(image, np.float64)
    if s == 1:
        return a
    h, w = a.shape[0] // s, a.shape[1] // s
    return a.reshape(h, s, w, s, *a.shape[2:]).mean(axis=(1, 3))


def _exact_rows(index, points, materials, n, k, t_trace, ref, mask_ref, ss, rows, backend,
                kdtree_shader: bool):
    """Exact-kNN caustic of one photon map: cKDTree (always) and the kd-tree shader (if asked)."""
    t = time.perf_counter()
    img = box_down(estimate_exact(index, points, materials, k=k, gpu=False), ss)
    base = {"photons": n, "k": k, "A": None, "preset": None, "variant": None,
            "rel_rms_exact": 0.0, "flux_ratio_exact": 1.0,
            "false_negatives": 0.0, "max_dilation": 1.0, "avg_dilation": 1.0}
    rows.append({"method": "exact-ckdtree", **base,
                 "seconds": {"trace": t_trace, "caustic_pass": time.perf_counter() - t},
                 **errors_against(img, ref.radiance, mask_ref, "reference")})
    if kdtree_shader:
        estimate_exact(index, points, materials, k=k, backend=backend)  # compiles
        t = time.perf_counter()
        gimg = box_down(estimate_exact(index, points, materials, k=k, backend=backend), ss)
        rows.append({"method": "exact-kdtree-shader", **base,
                     "seconds": {"trace": t_trace, "caustic_pass": time.perf_counter() - t},
                     **errors_against(gimg, ref.radiance, mask_ref, "reference")})
    return img


def with_plan(plan: SweepPlan, **changes) -> SweepPlan:
    """A copy of ``plan`` with some fields changed (``size``, ``photons``, ...)."""
    return replace(plan, **{k: v for k, v in changes.items() if v is not None})
