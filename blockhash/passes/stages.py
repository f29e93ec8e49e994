"""How a pass turns its photons into an image, chosen once per render (:func:`caustic_stage`):
the photons' radii, whether the cover gather runs, and the estimate (a GL pass, the CPU
reference or the exact kd-tree), for the caustic and the indirect photon maps alike."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockhash.frame.caustic import CausticPass, estimate_cpu, estimate_exact
from blockhash.frame.cover_estimate import cover_gather, estimate_cover_cpu
from blockhash.frame.photon_radius import exact_radii2, own_radii2


@dataclass(frozen=True)
class CausticStage:
    """How a pass turns its photons into the caustic, chosen once per render
    (:func:`caustic_stage`).

    radii : callable or None     the photons' own squared radii, ``radii(index, k)``
                                 (None: the k-nearest estimates' radius from the search)
    cover : bool                 the cover gather (records only, no hash tables; the pixel
                                 splat under the footprint, the gather built per pass)
    estimate : callable          ``estimate(setup, index, points, radii)``: (h, w, 3) float32
    """

    radii: object
    cover: bool
    estimate: object


def _gl_pass(gather: str):
    def estimate(setup, index, points, radii):
        cp = CausticPass(index, backend=setup.settings.backend, radii=radii, gather=gather)
        try:
            return cp.render(points, setup.materials, variant=setup.settings.variant,
                             options=setup.settings.estimate)
        finally:
            cp.release()
    return estimate


def _cover_cpu(setup, index, points, radii):
    s = setup.settings
    return estimate_cover_cpu(cover_gather(index, s.k, radii), points, setup.materials,
                              s.estimate).astype(np.float32)


def _knn_cpu(setup, index, points, radii):
    s = setup.settings
    return estimate_cpu(index, points, setup.materials, variant=s.variant, options=s.estimate,
                        radii=radii).astype(np.float32)


def _exact(setup, index, points, radii):
    s = setup.settings
    return estimate_exact(index, points, setup.materials, backend=s.backend, options=s.estimate,
                          radii=radii or exact_radii2).astype(np.float32)


def caustic_stage(settings) -> CausticStage:
    """The :class:`CausticStage` of ``settings`` (a :class:`.task.PassSettings`): its method
    and estimate (the one place that reads their names)."""
    conserving = settings.estimate.conserving
    radii = (exact_radii2 if settings.method == "kdtree" else own_radii2) if conserving else None
    if settings.method == "cover":
        return CausticStage(radii, True, _gl_pass("cover"))
    if settings.method == "bh":
        return CausticStage(radii, False, _gl_pass("knn"))
    if settings.method == "cpu":
        return CausticStage(radii, conserving, _cover_cpu if conserving else _knn_cpu)
    return CausticStage(radii, False, _exact)
