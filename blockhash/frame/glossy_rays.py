"""What the camera's rays do at glossy surfaces, for :mod:`.shading`: a rough mirror's or
glass's sampled microfacet (:func:`rough_events`, :mod:`blockhash.scene.microfacet`) and the
view through a coated receiver's coat (:func:`through_coat`, :mod:`blockhash.scene.coat`)."""

from __future__ import annotations

import numpy as np

#: Seed of the camera rays' microfacets on rough mirrors and glass (with the pass and the
#: event: each pass draws its own, so that passes average them).
ROUGH_SEED = 0x60F5


def rough_events(rays, idx, obj, d, n, outer, weight, pass_index: int, event: int):
    """The rough events (:func:`blockhash.scene.microfacet.rough_scatter`) of camera rays
    ``idx`` (the rays ``d`` on objects ``obj`` with normals ``n`` facing them, met from the
    ``outer`` side): their weights (rows ``idx`` of ``weight``) scaled in place; returns
    (new directions, sides: +1 reflected, -1 passed through, the density of each direction,
    :func:`blockhash.frame.rough_direct.sampling_pdf`).  The uniforms are pass
    ``pass_index``'s and event ``event``'s own, so that passes average the microfacets."""
    from blockhash.frame.rough_direct import sampled_pdf
    from blockhash.scene.microfacet import UNIFORMS, rough_scatter

    geom = rays.geometry
    u = np.random.default_rng([ROUGH_SEED, int(pass_index), int(event)]).random(
        (len(idx), UNIFORMS))
    dirs, factor, through = rough_scatter(d, n, n, outer, obj, geom.mirror, geom.is_dielectric,
                                          geom.ior, u)
    weight[idx] *= np.where(through[:, None], geom.tint[obj], 1.0) * factor
    return dirs, np.where(through, -1.0, 1.0), sampled_pdf(geom, -d, dirs, n, outer, obj)


def ray_pdf(pdf, start, end, obj) -> np.ndarray:
    """(m,) the density ``pdf`` of rays from ``start`` to ``end`` over their length squared,
    or where a ray hit nothing (``obj`` -1) the density itself
    (:attr:`blockhash.frame.shading_points.ShadingPoints.rough_pdf`)."""
    return np.where(obj < 0, pdf, pdf / np.maximum(np.sum((end - start) ** 2, axis=1), 1e-300))


def through_coat(weight, nrm, view, obj, geometry):
    """``weight`` with the points on coated receivers (objects ``obj``, -1: none; ``geometry``
    the ray caster's) seen through the coat: times its transmittance toward the viewer
    (:func:`blockhash.scene.coat.transmittance`)."""
    from blockhash.scene.coat import transmittance

    on = np.flatnonzero(obj >= 0)
    on = on[geometry.coat[obj[on]] > 0.0]
    if not len(on):
        return weight
    out = weight.copy()
    out[on] *= transmittance(np.sum(nrm[on] * view[on], axis=1), geometry.mirror,
                             obj[on])[:, None]
    return out
