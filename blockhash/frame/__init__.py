"""The frame: takes a scene, its photons and their index; gives a pass's image and its layers.

In the order a frame is made: the G-buffer and the camera's samples (:mod:`.gbuffer`,
:mod:`.subpixel`, :mod:`.camera_samples`), shading points (:mod:`.shading`), direct light (:mod:`.direct_light`),
the photon radii and the density estimate (:mod:`.photon_radius`, :mod:`.estimate`), the
search it uses (:mod:`.options`), the caustic pass in the fragment shader (:mod:`.caustic`: the
cover gather's or the k nearest's; :mod:`.cover_estimate` the cover gather's CPU reference),
the splat of photons under a pixel footprint into their pixel (:mod:`.pixel_splat`) and what a
render returns (:mod:`.result`; its files are :mod:`blockhash.evaluate.images`).

The render, a sequence of such frames, is :mod:`blockhash.passes`; its call is the function
``blockhash.render`` (:func:`blockhash.passes.pipeline.render`), as ``mitsuba.render`` is.
"""
