"""The frame: takes a scene, its photons and their index; gives the image and its layers.

In the order a frame is made: the G-buffer and the camera's samples
(:mod:`.gbuffer`, :mod:`.subpixel`), shading points and direct light
(:mod:`.shading`), the photon radii and the density estimate (:mod:`.photon_radius`,
:mod:`.estimate`), the caustic pass in the fragment shader (:mod:`.caustic`: the cover gather's
or the k nearest's; :mod:`.cover_estimate` the cover gather's CPU reference, :mod:`.splat` its
splatting peer), the pipeline that runs them (:mod:`.pipeline`) and image files (:mod:`.images`).

The render call itself is the function ``blockhash.render`` (:func:`.pipeline.render`), as
``mitsuba.render`` is.
"""
