"""The specular view identity: what a render shows in a mirror (or through glass) against what
it shows of the same receiver point directly.

On a Lambertian receiver (ks = 0) radiance leaves a point alike in every direction, so the
radiance seen at a pixel whose camera ray meets a perfect planar mirror of reflectance rho
and then the receiver at x is rho times the radiance of x seen directly.  Through a glass
slab (two parallel faces) the ray that refracts in and out carries (1 - F_in)(1 - F_out)
times the tint per crossing of x's radiance; the branches reflected at the faces add what
they see (for the caustic layer, nothing where they see no caustic).  Both layers obey it:
the caustic estimate at x and its direct light do not depend on the view direction.

:func:`specular_view_map` follows each pixel-centre ray through the chosen specular objects
(mirrors reflect, glass refracts: the transmitted branch) to its first diffuse hit x, and
projects x into the camera (:meth:`blockhash.scene.camera.Pinhole.project`'s film
coordinates), keeping the pixels where the ray from the eye toward x meets x itself (the
same receiver point seen unoccluded in both views).  :func:`compare_views` resamples a
layer at those film points, both views blurred to the coarser of their two pixel footprints
(the mapping's Jacobian: direct pixels per specular pixel), and reports the flux ratio and
blurred relative RMS over the kept pixels.  ``tools/mirror_identity.py`` runs it
(:func:`identity_check`) over seeds, whose spread is the limit: the render's own
noise in those pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import binary_erosion, map_coordinates, uniform_filter

from blockhash.errors import InputError
from blockhash.frame.scene_rays import SceneRays
from blockhash.scene.camera import Pinhole
from blockhash.scene.model import DielectricMaterial, MirrorMaterial
from blockhash.scene.optics import fresnel, refract
from blockhash.scene.raycast import RAY_OFFSET, reflect

#: Specular events followed from a pixel to its receiver point (a slab's two faces, or one
#: mirror bounce, need 2 at most).
MAX_EVENTS = 4


@dataclass
class ViewMap:
    """Pixels that see a receiver point through specular objects, and where the camera sees
    that point directly.

    pixels : (m,) int64      flat indices (row * width + col) of the specular view's pixels
    film : (m, 2) float64    film coordinates (x from the left, y from the top, pixels) of
                             their receiver points in the direct view
    weight : (m, 3)          the path weight: reflectances, (1 - F) tints
    footprint : float        direct pixels per specular pixel (median of the Jacobian)
    direct_ok : (h, w) bool  pixels that see, first, the receiver object of some kept pixel
    size : (width, height)
    """

    pixels: np.ndarray
    film: np.ndarray
    weight: np.ndarray
    footprint: float
    direct_ok: np.ndarray
    size: tuple

    @property
    def mask(self) -> np.ndarray:
        w, h = self.size
        m = np.zeros(h * w, dtype=bool)
        m[self.pixels] = True
        return m.reshape(h, w)


def _names(scene, names):
    known = [o.name for o in scene.objects]
    if names is None:
        names = [o.name for o in scene.objects if isinstance(o.material, (MirrorMaterial, DielectricMaterial))
                 and _planar(o.mesh)]
    for n in names:
        if n not in known:
            raise InputError(f"no object {n!r} in the scene; objects: {', '.join(known)}")
    if not names:
        raise InputError.about("the scene holds no planar mirror or glass object; name one with "
                               "{through}NAME")
    return [known.index(n) for n in names]


def _planar(mesh) -> bool:
    n = np.asarray(mesh.face_normals)
    return bool(len(n)) and bool(np.all(np.abs(n @ n[0]) > 1 - 1e-9))


def specular_view_map(scene, size=None, *, through=None) -> ViewMap:
    """The :class:`ViewMap` of the pixels whose camera ray meets one of the objects named
    ``through`` first (default: every planar mirror and every dielectric with flat faces) and
    reaches a diffuse receiver within :data:`MAX_EVENTS` events on those objects only."""
    pin = Pinhole.of(scene.camera, size)
    rays = SceneRays(scene.objects)
    ids = _names(scene, through)
    allowed = np.zeros(len(scene.objects) + 1, dtype=bool)
    allowed[ids] = True
    specular = np.array([o.is_specular for o in scene.objects] + [False])
    refl = np.array([np.broadcast_to(getattr(o.material, "reflectance", 1.0), 3)
                     for o in scene.objects] + [np.ones(3)], dtype=np.float64)
    glass = np.array([isinstance(o.material, DielectricMaterial) for o in scene.objects] + [False])
    ior = np.array([getattr(o.material, "ior", 1.0) for o in scene.objects] + [1.0])
    tint = np.array([np.broadcast_to(getattr(o.material, "tint", 1.0), 3)
                     for o in scene.objects] + [np.ones(3)], dtype=np.float64)
    d = pin.pixel_rays()
    n_pix = len(d)
    eye = np.broadcast_to(pin.eye, d.shape).copy()
    hit, p, ns, obj, _, outer = rays.first_hit(eye, d, sides=True)
    first = np.where(hit, obj, -1)
    idx = np.flatnonzero(allowed[first])
    pos, nrm, o, out, dirs = p[idx], ns[idx], first[idx], outer[idx], d[idx]
    weight = np.ones((len(idx), 3))
    live = np.ones(len(idx), dtype=bool)
    offset = RAY_OFFSET * rays.scale
    for _ in range(MAX_EVENTS):
        on = live & specular[o]
        if not on.any():
            break
        live &= allowed[o] | ~specular[o]  # a chain through another specular object is left out
        on &= live
        k = np.flatnonzero(on)
        g = glass[o[k]]
        new = reflect(dirs[k], nrm[k])
        side = np.ones(len(k))
        weight[k[~g]] *= refl[o[k[~g]]]
        if g.any():
            kg = k[g]
            eta = np.where(out[kg], 1.0 / ior[o[kg]], ior[o[kg]])
            f = fresnel(-np.sum(dirs[kg] * nrm[kg], axis=1), eta)
            t, tir = refract(dirs[kg], nrm[kg], eta)
            new[g] = t
            side[g] = -1.0
            weight[kg] *= (1.0 - f)[:, None] * tint[o[kg]]
            live[kg[tir]] = False
        origins = pos[k] + nrm[k] * (side * offset)[:, None]
        h2, p2, n2, o2, _, out2 = rays.first_hit(origins, new, sides=True)
        pos[k], nrm[k], out[k], dirs[k] = p2, n2, out2, new
        o[k] = np.where(h2, o2, -1)
    keep = live & (o >= 0) & ~specular[o]
    idx, pos, o, weight = idx[keep], pos[keep], o[keep], weight[keep]
    # the direct view: film coordinates of x, and the eye's ray toward x meets x itself
    v = pos - pin.eye
    fx, fy, z = pin.film_coords(pos)
    dist = np.linalg.norm(v, axis=1)
    h3, p3, _, o3, _ = rays.first_hit(np.broadcast_to(pin.eye, v.shape).copy(), v / dist[:, None])
    seen = (z > 0) & (fx >= 0) & (fx < pin.width) & (fy >= 0) & (fy < pin.height) & h3 & (o3 == o) \
        & (np.linalg.norm(p3 - pos, axis=1) < 1e-4 * rays.scale)
    idx, film, weight, o = idx[seen], np.stack([fx, fy], axis=1)[seen], weight[seen], o[seen]
    # direct pixels per specular pixel: the mapping's Jacobian from neighbouring pixel centres
    grid = np.full((n_pix, 2), np.nan)
    grid[idx] = film
    grid = grid.reshape(pin.height, pin.width, 2)
    gx = np.diff(grid, axis=1)[:-1]
    gy = np.diff(grid, axis=0)[:, :-1]
    jac = np.abs(gx[..., 0] * gy[..., 1] - gx[..., 1] * gy[..., 0])
    footprint = float(np.nanmedian(jac)) if np.isfinite(jac).any() else 1.0
    receivers = np.zeros(len(scene.objects) + 1, dtype=bool)
    receivers[np.unique(o)] = True
    direct_ok = (hit & receivers[np.where(hit, obj, -1)]).reshape(pin.height, pin.width)
    return ViewMap(pixels=idx, film=film, weight=weight, footprint=footprint,
                   direct_ok=direct_ok, size=(pin.width, pin.height))


def blur_widths(footprint: float) -> tuple[int, int]:
    """(box width on the specular view, box width on the direct view) that bring both to the
    coarser of their pixel footprints (odd, at least 1)."""
    side = float(np.sqrt(max(footprint, 1e-12)))
    odd = lambda x: max(1, 2 * int(round((x - 1) / 2)) + 1)  # noqa: E731
    return (odd(1.0 / side), 1) if side < 1 else (1, odd(side))


def predicted(view: ViewMap, layer: np.ndarray, *, extra: int = 1, order: int = 1):
    """(specular-view values (m', 3), predicted values (m', 3), kept flat pixels (m',)):
    ``layer`` at the specular view's pixels against the path weight times ``layer`` of the
    direct view at their receiver points (bilinear), both box-blurred to the coarser footprint
    times ``extra``; pixels whose blur would reach outside the specular view, or whose direct
    neighbourhood is not the receiver, are left out."""
    w, h = view.size
    ws, wd = blur_widths(view.footprint)
    ws, wd = ws * extra + (extra - 1) * (ws == 1), wd * extra + (extra - 1) * (wd == 1)
    ws, wd = ws | 1, wd | 1
    layer = np.asarray(layer, dtype=np.float64)
    spec = uniform_filter(layer, size=(ws, ws, 1), mode="nearest")
    direct = uniform_filter(layer, size=(wd, wd, 1), mode="nearest")
    inside = binary_erosion(view.mask, iterations=ws // 2 + 1)
    ok = binary_erosion(view.direct_ok, iterations=wd // 2 + 2)
    m = inside.reshape(-1)[view.pixels]
    x, y = view.film[:, 0] - 0.5, view.film[:, 1] - 0.5
    col, row = np.clip(np.round(x).astype(int), 0, w - 1), np.clip(np.round(y).astype(int), 0, h - 1)
    m &= ok[row, col]
    pix = view.pixels[m]
    a = spec.reshape(-1, 3)[pix]
    b = np.stack([map_coordinates(direct[..., c], [y[m], x[m]], order=order,
                                  mode="nearest")
                  for c in range(3)], axis=1) * view.weight[m]
    return a, b, pix


def compare_views(view: ViewMap, layer: np.ndarray, *, extra: int = 1,
                  bright: float = 0.05) -> dict:
    """Flux ratio (r, g, b) of the specular view over its prediction on the kept pixels, the
    blurred relative RMS of the two on the pixels above ``bright`` of the prediction's peak,
    and the counts (``predicted``)."""
    a, b, pix = predicted(view, layer, extra=extra)
    if not len(pix):
        return {"pixels": 0, "ratio": [float("nan")] * 3, "rel_rms": float("nan")}
    lum_b = b.sum(axis=1)
    sel = lum_b > bright * lum_b.max() if lum_b.max() > 0 else np.zeros(len(b), dtype=bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = a.sum(axis=0) / b.sum(axis=0)
        rel = float(np.sqrt(np.mean((a[sel] - b[sel]) ** 2)) / np.mean(b[sel])) if sel.any() \
            else float("nan")
    return {"pixels": int(len(pix)), "bright_pixels": int(sel.sum()),
            "ratio": [float(r) for r in ratio], "rel_rms": rel,
            "flux": [float(s) for s in a.sum(axis=0)], "predicted_flux": [float(s) for s in b.sum(axis=0)]}





def _noise(values: list) -> tuple[float, float]:
    """(relative standard deviation of the flux, blurred relative RMS about the mean) of the
    predicted images of several independent renders (lists of (m', 3) arrays)."""
    stack = np.stack(values)  # (runs, m', 3)
    k = len(stack)
    flux = stack.sum(axis=(1, 2))
    mean = stack.mean(axis=0)
    lum = mean.sum(axis=1)
    sel = lum > 0.05 * lum.max() if lum.max() > 0 else np.ones(len(lum), dtype=bool)
    spread = np.sqrt(np.mean((stack[:, sel] - mean[sel]) ** 2) * k / (k - 1))
    return float(np.std(flux, ddof=1) / np.mean(flux)), float(spread / np.mean(mean[sel]))


def _resampling(view, layer, linear) -> tuple[float, float]:
    """(flux ratio's difference, blurred relative RMS) between the bilinear prediction
    ``linear`` and the nearest-pixel one: what resampling the direct view alone moves."""
    near = predicted(view, layer, order=0)[1]
    lum = linear.sum(axis=1)
    sel = lum > 0.05 * lum.max() if lum.max() > 0 else np.ones(len(lum), dtype=bool)
    ratio = float(np.max(np.abs(near.sum(axis=0) / linear.sum(axis=0) - 1.0)))
    return ratio, float(np.sqrt(np.mean((near[sel] - linear[sel]) ** 2)) / np.mean(linear[sel]))


def identity_check(scene, *, size=(128, 128), photons=50_000, spp=4, seeds=(1, 2, 3, 4),
                   through=None, render=None) -> dict:
    """The identity on the caustic and direct layers over ``seeds`` (photon seeds for the
    caustic, jitter seeds for the direct layer), with its limits from their spread.

    Per layer: each run's flux ratio and blurred relative RMS (:func:`compare_views`), and
    ``limits``: the flux ratio within 3 standard deviations of one run's flux in those pixels
    from 1 (the flux's spread between runs), the blurred relative RMS within 2 times one run's
    own (the spread of the direct view's resampled images about their mean: two views, each
    that noisy), each plus the resampling's own error (bilinear against nearest-pixel
    sampling of the direct view: the flux ratio's difference and the relative RMS between
    the two predictions, the most of the runs); ``holds`` when every run is within both."""
    from blockhash.passes.pipeline import direct_layer, render_scene
    from blockhash.scene.camera import jitter_seed

    if len(seeds) < 2:
        raise InputError("the identity's limits come from the spread between runs: give two "
                         "seeds or more")
    render = render or render_scene
    view = specular_view_map(scene, size, through=through)
    if not len(view.pixels):
        raise InputError("no pixel sees a receiver point both through the specular objects and "
                         "directly, so no identity applies here (a floor seen only through glass "
                         "has no direct view to compare with)")
    out = {"pixels": int(len(view.pixels)), "footprint": view.footprint,
           "blur": list(blur_widths(view.footprint)), "layers": {}}
    for name in ("caustic", "direct"):
        runs, pred, resample = [], [], []
        for seed in seeds:
            if name == "caustic":
                layer = render(scene, photons=photons, size=size, spp=spp, seed=seed).caustic
            else:
                layer = direct_layer(scene, spp, size=size, seed=jitter_seed(seed))
            runs.append(compare_views(view, layer))
            pred.append(predicted(view, layer)[1])
            resample.append(_resampling(view, layer, pred[-1]))
        flux_sd, rms_noise = _noise(pred)
        r_ratio, r_rms = (max(r[i] for r in resample) for i in (0, 1))
        lim = {"ratio": 3.0 * flux_sd + r_ratio, "rel_rms": 2.0 * rms_noise + r_rms}
        holds = all(abs(c - 1.0) <= lim["ratio"] for r in runs for c in r["ratio"]) and \
            all(r["rel_rms"] <= lim["rel_rms"] for r in runs)
        out["layers"][name] = {"runs": runs, "flux_sd": flux_sd, "rms_noise": rms_noise,
                               "resampling": {"ratio": r_ratio, "rel_rms": r_rms},
                               "limits": lim, "holds": bool(holds)}
    return out
__all__ = ["ViewMap", "specular_view_map", "predicted", "compare_views", "blur_widths", "identity_check",
           "MAX_EVENTS"]
