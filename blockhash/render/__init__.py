"""The frame: takes a scene, its photons and their index; gives the image and its layers.

In the order a frame is made: the G-buffer and the camera's samples
(:mod:`.gbuffer`, :mod:`.subpixel`), shading points and direct light
(:mod:`.shading`), the photon radii and the density estimate (:mod:`.photon_radius`,
:mod:`.estimate`), the caustic pass in the fragment shader (:mod:`.caustic`), the
pipeline that runs them (:mod:`.pipeline`) and image files (:mod:`.images`).

The package is also the render call: ``blockhash.render(scene, photons=, spp=, seed=,
estimate=, lookup=, backend=, progress=)`` is :func:`blockhash.render.pipeline.render`
(as ``mitsuba.render``).  A module cannot be both a package and a function by name
alone, so the package's module object is made callable.
"""

import sys
import types


class _RenderModule(types.ModuleType):
    def __call__(self, scene, **settings):
        from blockhash.render.pipeline import render

        return render(scene, **settings)


sys.modules[__name__].__class__ = _RenderModule
