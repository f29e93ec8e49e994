"""Render a scene: caustic photons, Block Hashing index, G-buffer, direct light, caustic pass,
in passes.

``render`` (``blockhash.render``) runs a progressive render (:mod:`.progressive`: a fresh
photon batch and camera sample per pass, shrinking radii, running means) to a stopping rule
(:class:`.plan.RenderPlan`); ``render_scene`` (every setting a keyword) is one pass of it,
the single render with S x S stratified samples per pixel.  Both return the three layers
(direct, caustic, combined) and a summary of every phase; ``blockhash render`` writes them to
a multi-layer EXR and a tone-mapped PNG.  The default ``method='auto'`` gathers, for the
conserving estimate, every photon whose own disc covers the shading point (the cover gather,
in the shader) and for the k-nearest estimates the Block Hashing walk; ``method='bh'`` the
walk with every estimate; ``method='kdtree'`` the exact k nearest photons from the kd-tree
shader (the estimate itself in numpy) for comparison; ``method='cpu'`` the CPU reference of
what ``auto`` picks.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from blockhash.errors import InputError, NonFiniteError
from blockhash.frame.camera_samples import camera_points
from blockhash.frame.direct_light import direct_light
from blockhash.frame.estimate import EstimateOptions
from blockhash.frame.film_filter import filtered
from blockhash.frame.options import LookupOptions
from blockhash.frame.result import RenderResult  # noqa: F401 (importable from here)
from blockhash.frame.scene_rays import SceneRays
from blockhash.passes.executors import PassFailed, WorkersFailed
from blockhash.passes.plan import RenderPlan
from blockhash.passes.renderer import NoCausticWarning, Renderer  # noqa: F401 (importable from here)
from blockhash.passes.run import run_passes
from blockhash.passes.schedule import Schedule
from blockhash.scene.camera import DEFAULT_SPP, SPP_SEED, Pinhole, spp_grid
from blockhash.validate import old_keywords


def render(scene, *, photons=None, spp=None, seed=None, estimate=EstimateOptions(),
           lookup=LookupOptions(), backend=None, plan: RenderPlan | None = None) -> RenderResult:
    """Render ``scene`` (:func:`blockhash.load_scene`) in passes until ``plan`` says stop:
    its direct and caustic layers.

    Parameters
    ----------
    photons : int or CausticPhotons, optional
        Caustic photons stored per pass (default: the scene's ``[photons] count``; every pass
        after the first emits as many photons as the first did), or photons already traced
        (``blockhash.photons.tracing.trace_caustic_photons``) for a one-pass render, to
        compare lookups on one photon map (with the default ``plan``, :data:`ONE_PASS`).
    spp : int, optional
        Samples per pixel per pass, 1 to 1024 (default: the scene's ``[camera] spp``;
        else :data:`blockhash.scene.camera.DEFAULT_SPP` in a one-pass render and 1 per pass in
        a progressive one).
    seed : int, optional
        The photons' seed (default: the scene's ``[photons] seed``).
    estimate : EstimateOptions
        The density estimate (:mod:`blockhash.frame.estimate`).
    lookup : LookupOptions
        The photon search: method, k, A, shader variant.
    backend : {'auto', 'egl', 'osmesa'}, optional
    plan : RenderPlan, optional
        How the render proceeds: its stopping rule (most passes, seconds, target error), the
        radii's schedule, where the passes run and whether it renders the light between
        diffuse surfaces (``indirect``; :mod:`blockhash.passes.plan`); default
        ``RenderPlan()``, or one pass with every photon gathered for a traced map;
        ``RenderPlan(passes=1)`` is the single render of
        ``render_scene``.

    Returns
    -------
    RenderResult
        ``direct``, ``caustic``, ``combined`` and ``layers()``, ``timings`` per stage (summed
        over passes), ``info`` (passes, photons, estimated error, why it stopped), the last
        pass's ``index``, ``spp`` and ``passes``.  The image size is the camera's
        (``Scene.with_size`` for another).

    Raises
    ------
    PassFailed, WorkersFailed, NonFiniteError
        A pass raised, local workers kept dying (:mod:`blockhash.passes.executors`), or a
        pass's layer held NaN or infinity (the film refuses it, naming the layer, the pass,
        where it ran and its first pixel); the exception's ``image`` is the image of the
        passes merged before (None before the first), as the command line writes it.
    """
    if not isinstance(estimate, EstimateOptions):
        raise InputError(f"estimate must be an EstimateOptions; got {type(estimate).__name__} "
                         "(e.g. estimate=EstimateOptions(estimate='unbiased'))")
    if not isinstance(lookup, LookupOptions):
        raise InputError(f"lookup must be a LookupOptions; got {type(lookup).__name__} "
                         "(e.g. lookup=LookupOptions(method='kdtree', k=50))")
    if plan is not None and not isinstance(plan, RenderPlan):
        raise InputError(f"plan must be a RenderPlan; got {type(plan).__name__} "
                         "(e.g. plan=RenderPlan(passes=16) or RenderPlan(passes=None, seconds=30))")
    renderer, plan = make_renderer(scene, photons=photons, spp=spp, seed=seed,
                                   estimate=estimate, lookup=lookup, backend=backend, plan=plan)
    try:
        run_passes(renderer, plan)
    except (PassFailed, WorkersFailed, NonFiniteError) as exc:
        exc.image = renderer.image if renderer.passes else None  # the passes merged before
        raise
    return renderer.image


def make_renderer(scene, *, photons, spp, seed, estimate, lookup, backend,
                  plan: RenderPlan | None):
    """The :class:`.renderer.Renderer` that :func:`render` steps, and its plan (None:
    :class:`.plan.RenderPlan`'s defaults, or :data:`ONE_PASS` for a traced photon map, one
    pass's photons all gathered)."""
    traced = not (photons is None or isinstance(photons, (int, np.integer)))
    if plan is None:
        plan = ONE_PASS if traced else RenderPlan()
    renderer = Renderer(scene, photons=photons, spp=per_pass_spp(scene, spp, plan),
                        seed=seed, estimate=estimate, lookup=lookup, backend=backend,
                        schedule=plan.schedule, indirect=plan.indirect, device=plan.device)
    return renderer, plan


def per_pass_spp(scene, spp, plan: RenderPlan) -> int:
    """Samples per pixel per pass: ``spp``, else the scene's ``[camera] spp``, else
    :data:`DEFAULT_SPP` for one pass and 1 per pass for a progressive render."""
    if spp is not None:
        return spp
    if scene.camera.spp:
        return scene.camera.spp
    return DEFAULT_SPP if plan.one_pass else 1


#: render_scene's keywords that repeat fields of EstimateOptions.
_ESTIMATE_KEYWORDS = ("estimate", "filter", "normal_cos", "normal_test", "disc")


def render_scene(scene, *, photons=None, k=None, A=None, method="auto", variant="default",
                 size=None, seed=None, backend=None, photon_map=None,
                 options=None, spp=None, **deprecated) -> RenderResult:
    """One pass of :func:`render` with every setting a keyword (the single render with S x S
    stratified samples per pixel, every photon gathered: :data:`ONE_PASS`), which also takes an
    image ``size``.  The keywords
    ``estimate``, ``filter``, ``normal_cos``, ``normal_test`` and ``disc`` still work and
    warn (DeprecationWarning): give ``options=EstimateOptions(...)``, or call
    ``blockhash.render(scene, estimate=EstimateOptions(...))``.

    Parameters
    ----------
    photons, k, A, seed : optional
        Override the scene's ``[photons]`` settings.
    method : {'auto', 'cover', 'bh', 'kdtree', 'cpu'}
        :class:`~.options.LookupOptions`' method: 'auto' is the cover gather with the
        conserving estimate, the Block Hashing walk with the others.
    variant : str
        Shader variant of the Block Hashing lookup (``blockhash.gl.shaderlib.variants()``).
    size : (width, height), optional
        Override the camera's image size.
    photon_map : CausticPhotons, optional
        Reuse traced photons (for comparing methods on the same map).
    options : EstimateOptions, optional
        The density estimate's options (:mod:`blockhash.frame.estimate`; default:
        ``EstimateOptions()``).
    spp : int, optional
        Samples per pixel, 1 to 1024 (default: the scene's ``[camera] spp``, else
        :data:`blockhash.scene.camera.DEFAULT_SPP`).  1 shades the pixel centres the
        rasteriser gives; more casts one ray per cell of a stratified, jittered grid in each
        pixel (S x S for a square count, else rows x cols as near square as it divides,
        :func:`blockhash.scene.camera.spp_grid`; a fixed pattern,
        :data:`blockhash.scene.camera.SPP_SEED`), and every sample gets its own hit, direct light and caustic estimate (one caustic pass
        over all of them) before the camera's pixel filter weighs them into pixels.
    """
    old_keywords("render_scene", deprecated, _ESTIMATE_KEYWORDS,
                 "give options=EstimateOptions(...), or call "
                 "blockhash.render(scene, estimate=EstimateOptions(...))")
    if deprecated:
        normal_test = deprecated.pop("normal_test", True)
        options = EstimateOptions.of(options, **deprecated)
        if not normal_test:
            options = replace(options, normal_cos=None)
    lookup = LookupOptions(method=method, k=k, A=A, variant=variant)
    if size is not None:
        scene = scene.with_size(*size)
    return render(scene, photons=photons if photon_map is None else photon_map, spp=spp, seed=seed,
                  estimate=EstimateOptions.of(options), lookup=lookup, backend=backend,
                  plan=ONE_PASS)


#: The single render: one pass, every photon gathered (no pixel splat).
ONE_PASS = RenderPlan(passes=1, schedule=Schedule(footprint=0.0))


def direct_layer(scene, spp=None, *, size=None, backend=None, both_branches: bool = True,
                 seed: int = SPP_SEED) -> np.ndarray:
    """(h, w, 3) float32 pixels of the direct layer alone (under the camera's filter), as
    :func:`render_scene` computes it (no photons are traced): ``spp`` samples per pixel (default the scene's)."""
    grid = spp_grid((scene.camera.spp or DEFAULT_SPP) if spp is None else spp)
    rays = SceneRays(scene.objects)
    points, (x, y) = camera_points(scene, rays, grid, size=size, backend=backend,
                                   both_branches=both_branches, seed=seed)
    values = points.gather_direct(direct_light(points, scene.objects, scene.lights, rays))
    pin = Pinhole.of(scene.camera, size)
    return filtered(values, x, y, scene.camera.filter, pin.width, pin.height, grid)
