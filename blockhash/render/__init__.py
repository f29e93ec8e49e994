"""The caustic renderer: scenes to images, with the index and the GL side below it.

In the order a scene flows through it: the scene model and its TOML loader
(:mod:`.scene`, :mod:`.scene_toml`, :mod:`.scene_values`, :mod:`.meshes`), ray
casting (:mod:`.raycast`), photon emission and tracing (:mod:`.emission`,
:mod:`.tracing`), the G-buffer and shading points (:mod:`.gbuffer`,
:mod:`.shading`), the caustic pass (:mod:`.caustic`), the pipeline that runs them
(:mod:`.pipeline`), and image files (:mod:`.images`, :mod:`.preview`).
"""
