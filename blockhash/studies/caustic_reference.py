"""The caustic layer held to a cached Mitsuba reference, as ``tools/pass_convergence.py`` and
``tools/time_to_error.py`` measure it: their shared options (:func:`reference_options`: the
reference's samples per pixel, its cache, the worker processes of the passes, the JSON
output), where the passes run (:func:`executor`) and what a scene is compared on
(:func:`caustic_comparison`)."""

from __future__ import annotations

from pathlib import Path

#: Where the references are kept (``--cache``).
REFERENCE_CACHE = Path.home() / ".cache" / "blockhash" / "references"


def reference_options(parser, spp: int = 4096) -> None:
    """``--ref-spp``, ``--cache``, ``--workers`` and ``--json`` on a
    :class:`blockhash.studies.command.ToolParser`."""
    from blockhash.studies.command import count

    parser.add_argument("--ref-spp", type=count, default=spp,
                        help=f"the Mitsuba reference's samples per pixel (default {spp})")
    parser.add_argument("--cache", type=Path, default=REFERENCE_CACHE,
                        help=f"where references are kept (default {REFERENCE_CACHE})")
    parser.add_argument("--workers", type=workers, default=0, help="local worker processes "
                        "for the passes (default 0: in this process)")
    parser.json_output()


def workers(text: str) -> int:
    """A count of worker processes that may be 0."""
    from blockhash.studies.command import count

    return 0 if str(text).strip() in ("0", "0.0") else count(text)


def executor(workers: int):
    """Where the passes run: ``workers`` local processes, or this process for 0."""
    from blockhash.passes.executors import InProcess, LocalWorkers

    return LocalWorkers(workers) if workers else InProcess()


def caustic_comparison(path, size: int, spp: int, cache):
    """``(scene, mask, reference, seconds)`` for the scene file ``path`` at ``size`` x
    ``size``: the scene with ks = 0 (Mitsuba has no modified Phong lobe), the light tracer's
    comparison mask (receivers seen directly: Mitsuba's ptracer cannot reach the camera
    through a delta surface), and the cached Mitsuba caustic reference at ``spp`` samples per
    pixel with the seconds it took (None when read from the cache), cached under the file's stem."""
    from blockhash.reference.lighttrace import light_trace
    from blockhash.reference.mitsuba import cached_caustic, without_specular_lobes
    from blockhash.scene.loader import load_scene

    scene = without_specular_lobes(load_scene(path)).with_size(size, size)
    mask = light_trace(scene, 1000).comparison_mask(1)
    ref, seconds = cached_caustic(scene, Path(path).stem, size, spp, cache)
    return scene, mask, ref, seconds


def whole_comparison(path, size: int, spp: int, cache):
    """``(scene, mask, reference, seconds)`` for the whole image of the scene file ``path``
    at ``size`` x ``size``: the scene with ks = 0, the receivers the camera sees
    (:func:`blockhash.studies.lights.receivers_seen`), and Mitsuba's ``ptracer`` render of the
    whole scene at ``spp`` (seed 1) with the seconds it took (None when read from ``cache``,
    kept as ``NAME-SIZE-SPP-whole.npy``)."""
    import time

    import numpy as np

    from blockhash.frame.scene_rays import SceneRays
    from blockhash.reference.mitsuba import render_mitsuba, without_specular_lobes
    from blockhash.scene.loader import load_scene
    from blockhash.studies.lights import receivers_seen

    scene = without_specular_lobes(load_scene(path)).with_size(size, size)
    mask = receivers_seen(scene, SceneRays(scene.objects))
    file = Path(cache) / f"{Path(path).stem}-{size}-{spp}-whole.npy"
    if file.exists():
        return scene, mask, np.load(file), None
    t = time.perf_counter()
    ref, _ = render_mitsuba(scene, "ptracer", spp, seed=1)
    file.parent.mkdir(parents=True, exist_ok=True)
    np.save(file, ref)
    return scene, mask, ref, time.perf_counter() - t

