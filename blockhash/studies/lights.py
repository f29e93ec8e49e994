"""The light kinds measured (``tools/light_kinds.py``): what share of the photons each kind of
light shoots is stored, how fast, and how a scene lit by an area or a directional light agrees
with Mitsuba 3 (caustic flux and blurred caustic, direct light over the receivers, soft
shadows' convergence over passes)."""

from __future__ import annotations

import time

import numpy as np


def receivers_seen(scene, rays) -> np.ndarray:
    """(h, w) bool: pixels whose centre sees a diffuse object other than an area light's,
    away from its edges (the pixel and its 8 neighbours see the same object) and one pixel
    away from the lights: where a pixel's mean and its centre's value agree but for the
    shading's own variation."""
    from scipy.ndimage import binary_dilation, binary_erosion

    from blockhash.scene.camera import Pinhole

    pin = Pinhole.of(scene.camera)
    d = pin.pixel_rays()
    hit, _, _, obj, _ = rays.first_hit(np.broadcast_to(pin.eye, d.shape).copy(), d)
    obj = np.where(hit, obj, -1).reshape(pin.height, pin.width)
    lamps = [i for i, o in enumerate(scene.objects)
             if o.name in {getattr(li, "object", None) for li in scene.lights}]
    diffuse = np.array([not o.is_specular for o in scene.objects] + [False])
    m = diffuse[obj] & ~binary_dilation(np.isin(obj, lamps))
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            m &= np.roll(np.roll(obj, dy, 0), dx, 1) == obj
    return binary_erosion(m, border_value=0)


def direct_passes(scene, rays, passes: int, keep=()) -> dict:
    """{n: the direct layer's mean over passes 0..n-1} for each n of ``keep`` (and
    ``passes``): one camera sample and one light sample a pass, as a render's passes take
    them."""
    from blockhash.frame.camera_samples import camera_samples
    from blockhash.frame.direct_light import direct_light
    from blockhash.frame.subpixel import box_filter

    out, acc = {}, None
    for p in range(passes):
        points, _ = camera_samples(scene, rays, 1, p)
        img = box_filter(points.gather_direct(direct_light(points, scene.objects, scene.lights, rays, p)), 1)
        acc = img.astype(np.float64) if acc is None else acc + img
        if p + 1 in keep or p + 1 == passes:
            out[p + 1] = acc / (p + 1)
    return out


def efficiency(scene, photons: int, seed: int = 1) -> dict:
    """Pass 0 of ``scene`` at ``photons`` stored: photons shot and stored, the stored share,
    stored photons per second of tracing, and each light kind's share of the photons shot."""
    from blockhash.photons.tracing import PhotonSource

    t = time.perf_counter()
    source = PhotonSource(scene)
    setup = time.perf_counter() - t
    t = time.perf_counter()
    traced = source.until_stored(photons, seed=seed)
    seconds = time.perf_counter() - t
    stats = traced.stats
    kinds = sorted({type(li).__name__ for li in scene.lights})
    return {"lights": kinds, "stored": len(traced.positions), "emitted": traced.emitted,
            "stored_fraction": len(traced.positions) / max(traced.emitted, 1),
            "seconds": seconds, "setup_seconds": setup,
            "stored_per_second": len(traced.positions) / seconds if seconds > 0 else None,
            "fates": {k: stats.get(k, 0) for k in ("missed", "direct", "outside_spot", "escaped",
                                                     "absorbed", "max_bounces")}}


def soft_shadow_errors(scene, reference: np.ndarray, rays, passes=(4, 64)) -> dict:
    """The direct layer against ``reference`` over :func:`receivers_seen`: ``rel_rms``, its
    relative RMS after each of ``passes``; ``ratio``, its total over the reference's after
    the most; ``pixels``, how many were compared."""
    mask = receivers_seen(scene, rays)
    images = direct_passes(scene, rays, max(passes), keep=passes)
    return {"passes": list(passes),
            "rel_rms": [float(np.sqrt(((images[n] - reference)[mask] ** 2).mean())
                              / reference[mask].mean()) for n in passes],
            "ratio": float(images[max(passes)][mask].sum() / reference[mask].sum()),
            "pixels": int(mask.sum())}


__all__ = ["receivers_seen", "direct_passes", "efficiency", "soft_shadow_errors"]
