"""Where the camera's specular chain ends on a mirror, glass or glossy surface: the ray it
scatters there counts only the emitters it meets, as a path of Mitsuba's ``max_depth``
segments ends on an emitter (:func:`emission_met`, for :mod:`.shading`).

A camera ray followed through ``events`` specular events shades the diffuse point it reaches
(direct light, caustic and indirect photons: ``events`` + 2 segments with the light's);
where the last event leaves it on a specular or glossy surface, one more segment can only
end on a light: an area light's face or, leaving the scene, an environment light.  A mirror
that shows a lamp, rough plastic with a spherical light's highlight at ``max_depth`` 2
(Mitsuba's ``direct`` integrator) are that segment."""

from __future__ import annotations

import numpy as np

from blockhash.frame.surface_lights import emission_seen, environments_along


def emission_met(met, owner, weight, pos, view, obj, dirs, rays, lights, objects,
                 rough_pdf=None) -> None:
    """Adds to ``met[owner]`` the light that the last segments of camera rays meet, times
    their ``weight`` (m, 3): ``pos``, ``view`` (toward where each came from) and ``obj`` (-1:
    nothing hit) their ends, ``dirs`` (m, 3) their unit directions; an area light's
    radiance on its front face, an environment light's along the rays that hit nothing, each
    weighted against the light's own samples where a rough vertex sent the ray
    (``rough_pdf``, :attr:`.shading_points.ShadingPoints.rough_pdf`)."""
    if not len(owner):
        return
    seen = np.zeros((len(owner), 3))
    emission_seen(seen, lights, objects, pos, view, obj, rays, rough_pdf)
    gone = np.flatnonzero(obj < 0)
    if len(gone):
        seen[gone] += environments_along(lights, np.ascontiguousarray(dirs[gone], np.float64),
                                         None if rough_pdf is None else rough_pdf[gone])
    np.add.at(met, owner, weight * seen)
