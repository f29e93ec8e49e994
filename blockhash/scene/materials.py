"""The scene's materials: modified Phong receivers, perfect mirrors and smooth dielectrics.

Frozen dataclasses that validate their own fields (errors name the key, the expectation and
the way out); :mod:`.model` builds objects from them, :mod:`.loader` reads them from
``[materials.NAME]`` tables.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blockhash.scene.values import FieldError as _FieldError
from blockhash.scene.values import fmt as _fmt
from blockhash.scene.values import number as _number
from blockhash.scene.values import owned as _owned
from blockhash.scene.values import rgb as _rgb

#: The faces a receiver reflects on (:attr:`PhongMaterial.sided`).
SIDES = ("one", "two")


@dataclass(frozen=True, eq=False)
class PhongMaterial:
    """Modified Phong BRDF (Lafortune & Willems 1994), RGB:
    ``f = kd / pi + ks (n + 2) / (2 pi) cos^n(alpha)``, alpha the angle between
    the outgoing direction and the mirror direction of the incoming one.
    ``kd``, ``ks`` : (3,) float64 >= 0 with ``kd + ks <= 1`` per channel
    (energy conservation); ``n`` >= 0.

    ``sided``: ``"two"`` (the default) reflects on both faces of a surface; ``"one"`` only on
    its front face, the side its face normal points to (counter-clockwise winding), as
    Mitsuba's ``diffuse`` BSDF: seen or lit from the back it reflects nothing (no direct
    light, no stored photon, no caustic; black to the camera, and it still casts its shadow).

    ``coat`` > 1: the diffuse base lies under a smooth dielectric coat of that index of
    refraction (Mitsuba's ``plastic``, :mod:`blockhash.scene.coat`): the coat reflects
    specularly with Fresnel's reflectance times ``coat_reflectance``, and ``kd`` is the base's
    Lambertian factor seen through it (up to :func:`blockhash.scene.coat.largest_albedo`,
    above 1 for a white base under a dense coat; ``ks`` 0).  With ``alpha`` > 0 the coat is
    rough (Mitsuba's ``roughplastic``): its reflection a microfacet lobe of ``alpha`` and
    ``distribution`` (:func:`roughness`), and ``kd`` up to that coat's largest albedo."""

    kd: np.ndarray
    ks: np.ndarray
    n: float
    sided: str = "two"
    #: A diffuse reflectance that varies over the surface (:class:`blockhash.scene.texture.
    #: Texture`, looked up at the object's texture coordinates); ``kd`` is then its mean and
    #: ``ks`` must be 0.
    texture: object = None
    #: The index of refraction of a smooth dielectric coat over the base (0: none).
    coat: float = 0.0
    coat_reflectance: np.ndarray = field(default_factory=lambda: np.ones(3))
    #: The coat's microfacet roughness (0: a smooth coat) and distribution (:func:`roughness`).
    alpha: float = 0.0
    distribution: str = "beckmann"

    def __post_init__(self):
        with _owned("PhongMaterial"):
            roughness(self)
            if self.alpha > 0.0 and not self.coat:
                raise _FieldError("alpha", "a roughness is the coat's: give coat (its index of "
                                  "refraction) with alpha, or alpha 0")
            if self.texture is not None:
                from blockhash.scene.texture import Texture

                if not isinstance(self.texture, Texture):
                    raise _FieldError("texture", f"expected a Texture; got "
                                      f"{type(self.texture).__name__}")
                if np.any(np.asarray(self.ks, dtype=np.float64) != 0.0):
                    raise _FieldError("ks", "a textured reflectance is diffuse: ks must be 0 "
                                      "with a texture")
            if self.sided not in SIDES:
                raise _FieldError("sided", f"expected one of {', '.join(map(repr, SIDES))}; got "
                                  f"{self.sided!r}; \"one\" reflects on the front face only "
                                  "(Mitsuba's diffuse), \"two\" on both")
            kd = _rgb(self.kd, "kd", what="kd")
            ks = _rgb(self.ks, "ks", what="ks")
            n = _number(self.n, "n", lo=0.0, hint="the Phong exponent is >= 0")
            if self.coat:
                self._check_coat(kd, ks)
            elif np.any(kd + ks > 1.0):
                c = int(np.argmax(kd + ks))
                raise _FieldError("ks", f"kd + ks = {_fmt(kd + ks)} exceeds 1 in channel {'rgb'[c]}; "
                                  "expected kd + ks <= 1 per channel (energy conservation); "
                                  "lower kd or ks")
            object.__setattr__(self, "kd", kd)
            object.__setattr__(self, "ks", ks)
            object.__setattr__(self, "n", n)

    def _check_coat(self, kd, ks) -> None:
        from blockhash.scene.coat import largest_albedo

        coat = _number(self.coat, "coat", lo=1.0, hi=MAX_IOR, lo_open=True,
                       hint="the coat's index of refraction, e.g. 1.49 for polypropylene")
        object.__setattr__(self, "coat", coat)
        object.__setattr__(self, "coat_reflectance", _rgb(
            self.coat_reflectance, "coat_reflectance", hi=1.0, what="coat_reflectance"))
        if ks.any():
            raise _FieldError("ks", "a coated receiver is diffuse under its coat: ks must be 0")
        top = largest_albedo(coat, self.alpha, self.distribution)
        if np.any(kd > top + 1e-9):
            raise _FieldError("kd", f"kd = {_fmt(kd)} exceeds {top:.4g}, what a white base "
                              f"gives under this coat (index {coat:g}{_rough(self)}); lower kd")

    @property
    def one_sided(self) -> bool:
        """Reflects on its front face only (``sided == "one"``)."""
        return self.sided == "one"

    def __repr__(self) -> str:
        return (f"PhongMaterial(kd={_fmt(self.kd)}, ks={_fmt(self.ks)}, n={self.n:g}"
                + (", sided='one'" if self.one_sided else "")
                + (f", coat={self.coat:g}" if self.coat else "") + _rough(self)
                + (f", texture={self.texture!r})" if self.texture is not None else ")"))


@dataclass(frozen=True, eq=False)
class MirrorMaterial:
    """A smooth specular reflector; ``reflectance`` : (3,) float64 in [0, 1].

    Without ``eta`` and ``k`` a perfect mirror: every ray reflects with ``reflectance``.  With
    them ((3,) each, the real and imaginary parts of the metal's complex index of refraction
    per channel, the outside being air) a smooth conductor, as Mitsuba's ``conductor``:
    ``reflectance`` times the unpolarised Fresnel reflectance of the complex index at the
    angle of incidence (:func:`blockhash.scene.optics.conductor_fresnel`)."""

    reflectance: np.ndarray
    eta: np.ndarray | None = None
    k: np.ndarray | None = None
    #: Microfacet roughness (:func:`roughness`): 0, the default, a smooth mirror; above 0 a
    #: rough one, as Mitsuba's ``roughconductor``.
    alpha: float = 0.0
    distribution: str = "beckmann"

    def __post_init__(self):
        with _owned("MirrorMaterial"):
            roughness(self)
            object.__setattr__(self, "reflectance",
                               _rgb(self.reflectance, "reflectance", hi=1.0, what="reflectance"))
            if (self.eta is None) != (self.k is None):
                raise _FieldError("eta" if self.eta is None else "k",
                                  "missing: a conductor takes both eta and k (its complex index "
                                  "of refraction), a perfect mirror neither")
            if self.eta is not None:
                for name in ("eta", "k"):
                    v = _rgb(getattr(self, name), name, hi=MAX_CONDUCTOR_INDEX, what=name)
                    object.__setattr__(self, name, v)

    @property
    def is_conductor(self) -> bool:
        """Reflects by the Fresnel reflectance of ``eta`` and ``k`` (not a perfect mirror)."""
        return self.eta is not None

    def __repr__(self) -> str:
        extra = f", eta={_fmt(self.eta)}, k={_fmt(self.k)}" if self.is_conductor else ""
        return f"MirrorMaterial(reflectance={_fmt(self.reflectance)}{extra}{_rough(self)})"


#: Microfacet distributions of rough mirrors and glass, numbered as the compiled events read
#: them (:mod:`blockhash.scene.microfacet`).
DISTRIBUTIONS = ("beckmann", "ggx")
#: Largest microfacet roughness a material may have (Mitsuba's documentation calls 0.3 very
#: rough; past 1 the distributions stop describing a surface of facets).
MAX_ALPHA = 1.0


def roughness(material) -> None:
    """Checks a specular material's ``alpha`` (the microfacet distribution's roughness, the
    root mean square slope for ``beckmann``; 0 a smooth surface) and ``distribution`` (one of
    :data:`DISTRIBUTIONS`), and stores ``alpha`` as a float."""
    if material.distribution not in DISTRIBUTIONS:
        raise _FieldError("distribution", f"expected one of {', '.join(map(repr, DISTRIBUTIONS))}; "
                          f"got {material.distribution!r}")
    object.__setattr__(material, "alpha", _number(
        material.alpha, "alpha", lo=0.0, hi=MAX_ALPHA,
        hint="the microfacet roughness: 0 smooth, 0.01-0.3 polished to rough"))


def _rough(material) -> str:
    return (f", alpha={material.alpha:g}, distribution={material.distribution!r}"
            if material.alpha > 0.0 else "")


#: Largest real or imaginary part of a conductor's index of refraction a scene may give
#: (Mitsuba's tabulated metals reach about 10 in the visible).
MAX_CONDUCTOR_INDEX = 100.0


#: Largest index of refraction a dielectric may have (diamond is 2.42; germanium in the
#: infrared about 4).
MAX_IOR = 4.0


@dataclass(frozen=True, eq=False)
class DielectricMaterial:
    """A smooth dielectric (glass, water): ``ior`` the index of refraction (1 < ior <= 4,
    the outside being air, index 1) and ``tint`` (3,) float64 in [0, 1] the transmittance
    per crossing of the surface (default 1: clear).  Reflection and refraction follow
    Fresnel and Snell (:mod:`.optics`)."""

    ior: float
    tint: np.ndarray = field(default_factory=lambda: np.ones(3))
    #: Microfacet roughness (:func:`roughness`): 0, the default, smooth glass; above 0
    #: frosted, as Mitsuba's ``roughdielectric``.
    alpha: float = 0.0
    distribution: str = "beckmann"

    def __post_init__(self):
        with _owned("DielectricMaterial"):
            roughness(self)
            object.__setattr__(self, "ior", _number(
                self.ior, "ior", lo=1.0, hi=MAX_IOR, lo_open=True,
                hint="give the index of refraction, e.g. 1.5 for glass or 1.33 for water"))
            object.__setattr__(self, "tint", _rgb(self.tint, "tint", hi=1.0,
                                                  what="transmittance per crossing"))

    def __repr__(self) -> str:
        return f"DielectricMaterial(ior={self.ior:g}, tint={_fmt(self.tint)}{_rough(self)})"


#: Materials that scatter light specularly: they cast caustics and are followed, not shaded.
SPECULAR_MATERIALS = (MirrorMaterial, DielectricMaterial)


# --------------------------------------------------------------------------- the receivers' table

def phong_brdf(wi, wo, n, kd, ks, e):
    """Modified Phong f_r, vectorised: all (m, 3) except e (m,). Returns (m, 3)."""
    r = 2.0 * np.sum(n * wi, axis=1, keepdims=True) * n - wi
    c = np.maximum(np.sum(r * wo, axis=1), 0.0)
    return kd / np.pi + ks * ((e + 2.0) / (2.0 * np.pi) * c ** e)[:, None]


def receiver_materials(objects) -> list[tuple]:
    """The one material table of the receivers: ``(kd, ks, exponent)`` per object, in the
    scene's object order, zeros (exponent 1) for specular objects, which receive nothing."""
    table = []
    for obj in objects:
        m = obj.material
        if isinstance(m, PhongMaterial):
            table.append((tuple(float(x) for x in m.kd), tuple(float(x) for x in m.ks), float(m.n)))
        else:
            table.append(((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0))
    return table


def one_sided(objects) -> np.ndarray:
    """(len(objects) + 1,) bool: each object's material reflects on its front face only
    (:attr:`PhongMaterial.sided`), and False for the last entry, which index -1 ("nothing
    hit") reads."""
    return np.array([bool(getattr(o.material, "one_sided", False)) for o in objects] + [False])


def material_arrays(table) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A table of :func:`receiver_materials` as arrays: kd (M, 3), ks (M, 3), e (M,) float64."""
    kd = np.array([m[0] for m in table], dtype=np.float64).reshape(-1, 3)
    ks = np.array([m[1] for m in table], dtype=np.float64).reshape(-1, 3)
    e = np.array([m[2] for m in table], dtype=np.float64).reshape(-1)
    return kd, ks, e
