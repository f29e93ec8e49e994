"""The scene model: what is rendered.  Takes a TOML file or objects built in code;
gives a :class:`~blockhash.scene.model.Scene` (camera, lights, objects and their
materials) and the geometry queries on it.

:mod:`.values` checks field values for the loader, :mod:`.materials` is the one
material table (Phong, mirror, dielectric, and the receivers' BRDF parameters),
:mod:`.optics` the laws of reflection and refraction, :mod:`.camera` the pinhole
and the samples per pixel, :mod:`.model` the scene itself, :mod:`.meshes` the
meshes a scene file names, :mod:`.loader` the TOML format, :mod:`.raycast` ray
casting against the scene (embree), :mod:`.preview` a pyrender preview and
:mod:`.mitsuba` Mitsuba 3 XML (read and written).
"""
