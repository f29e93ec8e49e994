"""A published Mitsuba 3 scene rendered by blockhash and by Mitsuba from the same file, and
compared: what ``tools/mitsuba_folder.py`` tabulates and the tests of the published corpus
(``tests/data/mitsuba_published``) hold.

Each file is loaded by :func:`blockhash.load_scene` (its refusal, an :class:`InputError`,
is the row's answer, and every warning the import gives is kept); the image size is brought
down to ``size`` pixels on the longer side (the same field of view); blockhash renders the
combined image (direct, caustic and indirect layers) and Mitsuba renders the file as loaded,
its own integrator and ``max_depth`` (the integrator inside a ``stokes`` or ``moment``
wrapper, which its RGB variants refuse), at ``spp`` samples a pixel with its film resized
alike.
The comparison is over the whole image: the flux ratio (blockhash's sum over Mitsuba's, per
channel) and the relative RMS after a 5 x 5 box blur
(:func:`blockhash.studies.measure.box_blur_rel_rms`).
"""

from __future__ import annotations

import re
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from blockhash.errors import InputError


@dataclass
class Comparison:
    """One file's row: ``refused`` the import's message (nothing else then), else the
    warnings, the seconds of each render and the agreement."""

    path: Path
    refused: str | None = None
    warnings: list = field(default_factory=list)
    size: tuple = ()
    seconds: float = float("nan")
    mitsuba_seconds: float = float("nan")
    flux: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    blurred: float = float("nan")
    #: Mitsuba's own error where it did not render the file (blockhash's image stands alone).
    mitsuba_error: str | None = None
    #: Mitsuba's render at fewer samples against its reference, where asked (``peer_spp``).
    peer_blurred: float = float("nan")

    def as_dict(self) -> dict:
        return {"file": str(self.path), "refused": self.refused, "warnings": self.warnings,
                "size": list(self.size), "seconds": self.seconds,
                "mitsuba_seconds": self.mitsuba_seconds, "flux": np.asarray(self.flux).tolist(),
                "blurred_rel_rms": self.blurred, "mitsuba_error": self.mitsuba_error,
                "peer_blurred_rel_rms": self.peer_blurred}


def small_size(camera, side: int) -> tuple[int, int]:
    """(width, height) with the longer side ``side`` and the camera's aspect."""
    scale = side / max(camera.width, camera.height)
    return max(1, round(camera.width * scale)), max(1, round(camera.height * scale))


def load(path, defines: dict | None = None) -> tuple:
    """(scene or None, the refusal's message or None, the warnings' messages); ``defines``
    the file's parameters, as Mitsuba's ``-D``."""
    from blockhash.scene.loader import load_scene

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            scene = load_scene(path, defines)
        except InputError as exc:
            return None, str(exc), [str(w.message) for w in caught]
    return scene, None, [str(w.message) for w in caught]


def mitsuba_render(path, size, spp: int, seed: int = 0, defines: dict | None = None,
                   integrator: dict | None = None) -> tuple[np.ndarray, float]:
    """(image (h, w, 3) float64, seconds) of Mitsuba's render of the file at ``path`` as it
    is (``defines`` its parameters), its film resized to ``size`` (None: as the file has it),
    by the file's integrator or ``integrator`` (a :func:`mitsuba.load_dict` description);
    read from the folder of kept renders where one holds it (:mod:`.reference_cache`), and
    kept there."""
    from blockhash.reference.mitsuba import load_mitsuba_module
    from blockhash.studies import reference_cache

    mi, variant = load_mitsuba_module()
    key = reference_cache.render_key(
        path, size or (), spp, seed,
        defines if integrator is None else {**(defines or {}), " integrator": integrator},
        f"{mi.__version__} {variant}")
    found = reference_cache.kept(key)
    if found is not None:
        return found
    given = {k: str(v) for k, v in (defines or {}).items()}
    try:
        try:
            scene = mi.load_file(str(path), **given)
        except RuntimeError as exc:  # Mitsuba refuses a parameter the file does not use
            unused = set(re.findall(r"\$(\w+)=", str(exc))) if "unused parameters" in str(exc) else set()
            if not unused:
                raise
            scene = mi.load_file(str(path), **{k: v for k, v in given.items() if k not in unused})
    except RuntimeError as exc:  # a stokes or moment wrapper: RGB variants refuse it
        if "polarized mode" not in str(exc) and "moment" not in str(exc):
            raise
        scene = _unwrapped(mi, Path(path))
    if size is not None:
        _resize_film(mi, scene, size)
    given = {} if integrator is None else {"integrator": mi.load_dict(integrator)}
    t = time.perf_counter()
    image = np.asarray(mi.render(scene, spp=int(spp), seed=int(seed), **given),
                       dtype=np.float64)[..., :3]
    seconds = time.perf_counter() - t
    reference_cache.keep(key, image, seconds)
    return image, seconds


def compare(path, *, size: int = 64, spp: int = 1024, passes: int = 8, photons=None,
            samples: int | None = None, seed: int = 1, defines: dict | None = None,
            peer_spp: int | None = None) -> Comparison:
    """The :class:`Comparison` of the file at ``path`` (module docstring): Mitsuba at ``spp``
    samples a pixel, blockhash in ``passes`` passes of ``samples`` a pixel each (None: the
    file's ``sample_count``) and ``photons`` a pass (None: blockhash's default); ``defines``
    the file's parameters for both, as Mitsuba's ``-D``.  With ``peer_spp``, Mitsuba's own
    render at that many samples a pixel (another seed) against the same reference too
    (:attr:`Comparison.peer_blurred`): the error an unbiased render reaches at that count."""
    import blockhash
    from blockhash.passes.plan import RenderPlan
    from blockhash.studies.measure import box_blur_rel_rms

    path = Path(path)
    scene, refused, caught = load(path, defines)
    out = Comparison(path, refused=refused, warnings=caught)
    if scene is None:
        return out
    out.size = small_size(scene.camera, size)
    scene = scene.with_size(*out.size)
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = blockhash.render(scene, photons=photons, seed=seed, spp=samples,
                                  plan=RenderPlan(passes=passes))
    out.seconds = time.perf_counter() - t
    ours = np.asarray(result.combined, dtype=np.float64)
    try:
        theirs, out.mitsuba_seconds = mitsuba_render(path, out.size, spp, defines=defines)
    except RuntimeError as exc:  # the peer's own refusal: the row says so, the table goes on
        out.mitsuba_error = str(exc).splitlines()[0]
        return out
    out.flux = ours.sum(axis=(0, 1)) / np.maximum(theirs.sum(axis=(0, 1)), 1e-300)
    everywhere = np.ones(ours.shape[:2], dtype=bool)
    out.blurred = box_blur_rel_rms(ours, theirs, everywhere)
    if peer_spp:
        peer, _ = mitsuba_render(path, out.size, peer_spp, seed=1, defines=defines)
        out.peer_blurred = box_blur_rel_rms(peer, theirs, everywhere)
    return out


def _resize_film(mi, scene, size) -> None:
    """Mitsuba's ``scene`` with its film resized to ``size`` (a crop window keeps its place)."""
    params = mi.traverse(scene.sensors()[0])
    full, crop = np.array(params["film.size"], float), np.array(params["film.crop_size"], float)
    scale = np.array(size, float) / crop
    params["film.size"] = mi.ScalarVector2u(*np.round(full * scale).astype(int).tolist())
    params["film.crop_offset"] = mi.ScalarPoint2u(
        *np.round(np.array(params["film.crop_offset"], float) * scale).astype(int).tolist())
    params["film.crop_size"] = mi.ScalarVector2u(*size)
    params.update()


def _unwrapped(mi, path: Path):
    """Mitsuba's scene of the file at ``path`` with its top-level ``stokes`` or ``moment``
    integrator replaced by the integrator inside, as blockhash renders it (Mitsuba's RGB
    variants refuse the wrappers)."""
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    for i, el in enumerate(list(root)):
        if el.tag == "integrator" and el.get("type") in ("stokes", "moment"):
            inner = el.find("integrator")
            root.remove(el)
            if inner is not None:
                root.insert(i, inner)
    mi.file_resolver().prepend(str(path.parent))
    return mi.load_string(ET.tostring(root, encoding="unicode"))
