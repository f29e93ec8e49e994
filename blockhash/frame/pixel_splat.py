"""A focus smaller than a pixel, filtered over the pixel: photons splatted into the pixel that
sees them.

Where photons pile up tighter than a pixel (the focus under a glass ball), their own discs
are far smaller than the pixel's footprint: a camera sample that lands inside the focus
stands for the whole pixel, one that misses it for nothing, and a few samples per pixel
give the focus's pixel 38 times its mean or nothing.  The mean that pixel should hold is the
flux the focus sends toward the camera over the pixel's footprint, which is what a light
tracer's camera connection estimates (:mod:`blockhash.reference.lighttrace`):

    L_pixel += Phi f_r(wi, wo) cos(theta_x) / (A_pixel cos^3(theta_c) d^2)

for a photon at distance d, seen at cos(theta_x) from its surface and cos(theta_c) off the
camera's axis (A_pixel the pixel's area on the image plane at distance 1).  A photon under the
footprint (:mod:`blockhash.passes.schedule` says which) that the camera sees directly (in the
image, on the side it faces, nothing between) is splatted into its pixel this way; every other
photon stays in the gather, and so does every photon on a textured receiver (its reflectance
is the texture's where the camera's point is, :mod:`blockhash.scene.texture`).  Each photon's
power goes to one estimate, so the flux is kept.  A photon seen only in a mirror or through
glass stays in the gather: its pixel is not where it projects.
"""

from __future__ import annotations

import numpy as np

from blockhash.scene.materials import material_arrays, phong_brdf


def splat_subpixel(photons, r2: np.ndarray, pin, rays, materials, *, footprint: float,
                   spread=None):
    """``(image, keep)``: the (h, w, 3) float64 pixel means of the photons splatted (module
    docstring) and the (n,) bool mask of the photons left to the gather.

    ``photons``: a pass's ``CausticPhotons`` with their receiving ``objects``; ``r2`` their
    squared own radii (input order); ``pin``: the camera (:class:`blockhash.scene.camera.Pinhole`);
    ``rays``: :class:`.scene_rays.SceneRays` of the scene; ``materials``: the receiver table;
    ``spread``: None (each photon in the pixel it projects to: the box filter), or
    ``spread(x, y, contrib)`` -> (h w, 3), the pixels of contributions at film points
    ``(x, y)`` under the camera's filter (:func:`.film_filter.spread`).
    """
    n = len(photons.positions)
    image = np.zeros((pin.height * pin.width, 3))
    keep = np.ones(n, dtype=bool)
    if not n or footprint <= 0 or photons.objects is None:
        return image.reshape(pin.height, pin.width, 3), keep
    material = material_arrays(materials)
    for first in range(0, n, CHUNK):  # float64 working arrays of CHUNK photons at a time
        rows = slice(first, min(n, first + CHUNK))
        _splat_rows(photons, rows, r2[rows], pin, rays, material, footprint, image, keep[rows],
                    spread)
    return image.reshape(pin.height, pin.width, 3), keep


#: Photons splatted at a time: the working arrays (about 200 bytes a photon) stay a few
#: tens of MiB whatever the map's size.
CHUNK = 1 << 17


def _splat_rows(photons, rows: slice, r2, pin, rays, material, footprint, image, keep,
                spread) -> None:
    """Add the splat of ``photons[rows]`` to ``image`` (flat, (h w, 3)); clear ``keep`` (that
    slice of the map's mask) where a photon is splatted."""
    x = np.asarray(photons.positions[rows], np.float64)
    to_eye = pin.eye - x
    d2 = np.einsum("ij,ij->i", to_eye, to_eye)
    pixel_angle = 2.0 * pin.tan_y / pin.height
    small = 4.0 * r2 < (footprint * pixel_angle) ** 2 * d2
    if len(rays.geometry.textures):  # a textured receiver's photons stay in the gather
        small &= rays.geometry.texture_of[np.asarray(photons.objects[rows])] < 0
    idx = np.flatnonzero(small)
    if not idx.size:
        return
    wo = to_eye[idx] / np.sqrt(d2[idx])[:, None]
    ns = np.asarray(photons.normals[rows][idx], np.float64)
    cos_x = np.einsum("ij,ij->i", ns, wo)
    pix, cos_c = pin.project(x[idx])
    ok = (cos_x > 0) & (pix >= 0)
    ok[ok] = rays.visible(x[idx[ok]], ns[ok], np.broadcast_to(pin.eye, (int(ok.sum()), 3)))
    idx, wo, ns, cos_x, pix, cos_c = idx[ok], wo[ok], ns[ok], cos_x[ok], pix[ok], cos_c[ok]
    if not idx.size:
        return
    kd, ks, e = material
    obj = photons.objects[rows][idx]
    f = phong_brdf(-np.asarray(photons.directions[rows][idx], np.float64), wo, ns, kd[obj],
                   ks[obj], e[obj])
    weight = cos_x / (pin.pixel_area * cos_c ** 3 * d2[idx])
    contrib = np.asarray(photons.powers[rows][idx], np.float64) * f * weight[:, None]
    if spread is None:
        for c in range(3):
            image[:, c] += np.bincount(pix, contrib[:, c], minlength=len(image))
    else:
        fx, fy, _ = pin.film_coords(x[idx])
        image += spread(fx, fy, contrib)
    keep[idx] = False
