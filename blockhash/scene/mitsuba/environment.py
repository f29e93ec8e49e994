"""Mitsuba 3's ``constant`` and ``envmap`` emitters (for :mod:`.importer`): :func:`constant`
and :func:`envmap`, each an :class:`~blockhash.scene.environment_light.EnvironmentLight`."""

from __future__ import annotations

import numpy as np

from blockhash.errors import InputError
from blockhash.scene.environment_light import EnvironmentLight
from blockhash.scene.texture import read_image

#: The smallest map Mitsuba's envmap takes (2 x 3 pixels): a ``constant`` emitter's, every
#: pixel its radiance.
CONSTANT_MAP = (3, 2)


def constant(r, el) -> EnvironmentLight:
    """The :class:`EnvironmentLight` of a ``constant`` emitter: its ``radiance`` from every
    direction, a map of that radiance everywhere (the bilinear lookup of a constant map is the
    constant), so its photons cross the scene's disc, its direct light is sampled with shadow
    rays and the camera sees it where a ray leaves the scene, as any environment map's."""
    p = r.props(el, {"radiance": ("rgb", "spectrum", "float")}, emitter=True)
    radiance = np.broadcast_to(p.get("radiance", 1.0), (3,))
    return r.build(el, EnvironmentLight, image=np.broadcast_to(radiance, (*CONSTANT_MAP, 3)),
                   name=el.get("id") or "constant-environment")


def add_constant(r, el, lights: list) -> None:
    """Adds a ``constant`` emitter to ``lights`` (changed in place): its :func:`constant` map,
    or where an ``envmap`` is there already its radiance added to every pixel of that map (the
    two emitters as one environment light)."""
    sky = constant(r, el)
    for i, light in enumerate(lights):
        if isinstance(light, EnvironmentLight):
            lights[i] = EnvironmentLight(light.image + sky.image[0, 0], light.to_world, light.name)
            return
    lights.append(sky)


def envmap(r, el) -> EnvironmentLight:
    """The :class:`EnvironmentLight` of an ``envmap`` emitter: its ``filename`` (found as a
    mesh file is, :meth:`resolve`) read by :func:`blockhash.scene.texture.read_image`, times ``scale``, turned by
    ``to_world``'s rotation.  ``mis_compensation`` changes only how Mitsuba samples the map,
    not the image: accepted without a word."""
    p = r.props(el, {"filename": ("string",), "scale": ("float",), "to_world": ("transform",),
                     "mis_compensation": ("boolean",)}, emitter=True)
    if "filename" not in p:
        r.fail(el, "an envmap needs its image: add <string name=\"filename\" value=\"sky.exr\"/>")
    path = r.resolve(el, p["filename"], "environment map")
    try:
        image = read_image(path)
    except InputError as exc:
        r.fail(el, str(exc))
    scale = float(p.get("scale", 1.0))
    if not scale > 0.0:
        r.fail(el, f"scale {scale:g}: an environment map's scale must be > 0")
    m = p.get("to_world", np.eye(4))[:3, :3]
    return r.build(el, EnvironmentLight, image=image * scale, to_world=m,
                   name=el.get("id") or path.name)
