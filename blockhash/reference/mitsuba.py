"""A reference from Mitsuba 3 under blockhash's layer names (``blockhash reference --engine
mitsuba``; the optional extra ``blockhash[mitsuba]``).

The scene goes to Mitsuba through :mod:`blockhash.scene.mitsuba.exporter` (modified Phong lobes
dropped: Mitsuba has none, so compare with a render of the scene with ks = 0), and each layer
is one or two Mitsuba renders at ``spp`` samples per pixel:

* **caustic**: Mitsuba's particle tracer (``ptracer``, unbiased for light that reaches a
  diffuse surface over specular ones), ``max_depth`` the scene's specular events per photon
  plus 2 (the chain blockhash's photons follow), of the scene with every diffuse albedo
  multiplied by :data:`ALBEDO_SCALE`, less the same render with every specular object made
  a black diffuse absorber (same seed, so the paths that never meet a specular surface
  cancel sample by sample), divided by :data:`ALBEDO_SCALE`.  The difference holds the
  light paths that meet a mirror or glass before their last diffuse vertex.  A path's
  contribution is proportional to the product of the albedos at its diffuse vertices, so
  after the division the paths of one diffuse vertex, L S+ D E (blockhash's caustic), keep
  their value and their noise exactly (the albedo scales the connection to the camera, a
  deterministic factor), while those of two or more (diffusely reflected light refocused by
  a mirror, L D S+ D E, and a caustic's further diffuse bounces, L S+ D D E) are scaled down
  by ALBEDO_SCALE or more: on venus, whose ring sits beside the lit bust, they are 37% of
  the plain difference, 0.6% of it at a scale of 1/64.  The closed Cornell box, whose walls
  are all lit and seen in the mirror ball, has more of them: at 1/1024 the light tracer and
  this isolation agree there within 1% (``tools/mitsuba_agreement.py --scenes cbox``).  Like blockhash's light tracer, the particle
  tracer sees no caustic through a mirror or glass (it cannot connect to a pinhole through
  a delta surface).
* **direct**: Mitsuba's path tracer (``path``) with the depth the scene's specular chains
  need: lights seen over diffuse surfaces, directly or through mirrors and glass.  Point,
  spot and directional lights cannot be reached over a specular surface from the camera, so
  no caustic of theirs is in it, but an area light's is (a path tracer reaches it by sampling
  the glass); diffuse interreflection is in it too (a floor lit by a wall), which blockhash
  renders in its indirect layer.  For the direct layer alone, :func:`render_mitsuba` with
  ``max_depth=2`` (emitters seen and lit directly).

Mitsuba's LLVM variant (``llvm_ad_rgb``) needs an LLVM shared library (16 or newer); the
module finds a system one (``DRJIT_LIBLLVM_PATH``, else ``libLLVM-*.so`` under the usual
library folders) and falls back to ``scalar_rgb`` without one.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, field, replace

import numpy as np

from blockhash.device.choice import find_llvm
from blockhash.errors import InputError
from blockhash.scene.materials import PhongMaterial
from blockhash.scene.model import SceneObject

#: The diffuse albedos' factor in the caustic's renders (module docstring): a power of two,
#: so the scaling and the division are exact in float32.
ALBEDO_SCALE = 1.0 / 1024.0
#: The variants tried, fastest first.
VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
INSTALL_HINT = ("install the extra: pip install 'blockhash[mitsuba]' (and, for the fast LLVM "
                "variant, an LLVM >= 16 shared library, e.g. apt-get install libllvm19)")


def load_mitsuba_module():
    """``(mitsuba, variant)``: the module with the fastest variant set that works here.
    Raises InputError naming the way out when Mitsuba is not installed."""
    find_llvm()
    try:
        import mitsuba as mi
    except ImportError as exc:
        raise InputError(f"the Mitsuba engine needs the mitsuba package ({exc}); "
                         f"{INSTALL_HINT}") from None
    for variant in VARIANTS:
        if variant not in mi.variants():
            continue
        try:
            mi.set_variant(variant)
            if variant.startswith("llvm"):
                import drjit as dr
                dr.eval(dr.llvm.Float(1.0) + 1.0)  # fails here without a working LLVM
            return mi, variant
        except (ImportError, RuntimeError, AttributeError):
            continue
    raise InputError(f"no Mitsuba variant of {VARIANTS} works here; {INSTALL_HINT}")


def mitsuba_available() -> tuple[bool, str]:
    """(whether :func:`mitsuba_reference` can run, the reason when not)."""
    try:
        load_mitsuba_module()
    except InputError as exc:
        return False, str(exc)
    return True, ""


@dataclass
class MitsubaReference:
    """The layers (h, w, 3) float32 of a Mitsuba reference and the seconds each took."""

    direct: np.ndarray
    caustic: np.ndarray
    spp: int
    variant: str
    timings: dict = field(default_factory=dict)

    @property
    def combined(self) -> np.ndarray:
        return self.direct + self.caustic

    def layers(self) -> dict:
        return {"direct": self.direct, "caustic": self.caustic, "combined": self.combined}


def absorbing(scene):
    """``scene`` with every specular object a black diffuse absorber (it still casts its
    shadow, and light that reaches it ends there)."""
    black = PhongMaterial(kd=0.0, ks=0.0, n=0.0)
    objects = tuple(SceneObject(name=o.name, mesh=o.mesh, material=black) if o.is_specular else o
                    for o in scene.objects)
    return replace(scene, objects=objects)


def dimmed(scene, factor: float):
    """``scene`` with every modified Phong albedo kd multiplied by ``factor`` (ks dropped,
    the faces it reflects on kept)."""
    objects = tuple(SceneObject(name=o.name, mesh=o.mesh, material=PhongMaterial(
        kd=o.material.kd * factor, ks=0.0, n=0.0, sided=o.material.sided))
        if isinstance(o.material, PhongMaterial) else o
        for o in scene.objects)
    return replace(scene, objects=objects)


def without_specular_lobes(scene):
    """``scene`` with ks = 0 on every modified Phong material (what the export writes)."""
    return dimmed(scene, 1.0)


def render_mitsuba(scene, integrator: str, spp: int, *, seed: int = 0, size=None,
                   max_depth: int | None = None) -> tuple:
    """(image (h, w, 3) float32, seconds) of one Mitsuba render of ``scene`` with
    ``integrator`` (``ptracer`` or ``path``) at ``spp`` samples per pixel and ``max_depth``
    (default :func:`blockhash.scene.mitsuba.exporter.scene_xml`'s); the seconds count the
    render only, not the export and load."""
    from blockhash.scene.mitsuba.exporter import export_mitsuba

    mi, _ = load_mitsuba_module()
    if size is not None:
        scene = scene.with_size(*size)
    with tempfile.TemporaryDirectory(prefix="blockhash-mitsuba-") as tmp:
        xml = export_mitsuba(scene, tmp, drop_specular=True, spp=spp, integrator=integrator,
                             max_depth=max_depth)
        loaded = mi.load_file(str(xml), spp=int(spp))
        t = time.perf_counter()
        image = np.asarray(mi.render(loaded, spp=int(spp), seed=int(seed)), dtype=np.float32)
        seconds = time.perf_counter() - t
    return image[..., :3].copy(), seconds


def mitsuba_reference(scene, spp: int, *, seed: int = 0, size=None,
                      layers=("direct", "caustic"), integrator: str = "ptracer") -> MitsubaReference:
    """The Mitsuba reference of ``scene`` (module docstring) at ``spp`` samples per pixel;
    ``integrator`` renders the caustic's pair (``ptracer``, or ``path``, which reaches an
    area light's caustic from the camera side; the isolation is the same: a path's value is
    the product of its diffuse albedos either way)."""
    if integrator not in ("ptracer", "path"):
        raise InputError(f"integrator={integrator!r}: the caustic is isolated from Mitsuba's "
                         "'ptracer' or 'path'; give one of those")
    spp = int(spp)
    if spp < 1:
        raise InputError(f"spp={spp} must be >= 1 samples per pixel")
    _, variant = load_mitsuba_module()
    w, h = size or (scene.camera.width, scene.camera.height)
    timings = {}
    direct = caustic = np.zeros((h, w, 3), np.float32)
    if "caustic" in layers:
        dim = dimmed(scene, ALBEDO_SCALE)
        full, timings[f"caustic ({integrator})"] = render_mitsuba(dim, integrator, spp,
                                                                  seed=seed, size=size)
        rest, timings[f"caustic ({integrator}, specular absorbing)"] = render_mitsuba(
            absorbing(dim), integrator, spp, seed=seed, size=size)
        caustic = (full - rest) / np.float32(ALBEDO_SCALE)
    if "direct" in layers:
        direct, timings["direct (path)"] = render_mitsuba(scene, "path", spp, seed=seed, size=size)
    return MitsubaReference(direct=direct, caustic=caustic, spp=spp, variant=variant,
                            timings=timings)


__all__ = ["mitsuba_reference", "render_mitsuba", "dimmed", "ALBEDO_SCALE", "mitsuba_available", "MitsubaReference",
           "absorbing", "without_specular_lobes", "load_mitsuba_module"]


def cached_caustic(scene, name: str, size: int, spp: int, cache):
    """(the caustic layer of :func:`mitsuba_reference` at ``spp`` (seed 1), seconds it took or
    None when read from ``cache``): kept as ``cache/NAME-SIZE-SPP.npy`` for the tools that
    measure against one reference many times (the name carries the albedo scale, so a
    reference isolated at another is not read)."""
    from pathlib import Path

    path = Path(cache) / f"{name}-{size}-{spp}-albedo{round(1 / ALBEDO_SCALE)}.npy"
    if path.exists():
        return np.load(path), None
    t = time.perf_counter()
    ref = mitsuba_reference(scene, spp, seed=1, layers=("caustic",)).caustic
    path.parent.mkdir(parents=True, exist_ok=True)
    np.save(path, ref)
    return ref, time.perf_counter() - t
