"""Mitsuba 3's ``<integrator>`` (for :mod:`.importer`): :func:`integrator` (a ``moment`` or
``stokes`` wrapper's inner integrator) and :func:`depths`, its ``max_depth`` as the specular
events blockhash's photons and camera rays follow.

``direct``: direct light only (one warning saying what differs).  ``path`` or ``ptracer``:
``max_depth`` -1 (Mitsuba's default, unbounded) keeps blockhash's depth (4 specular events, 8
in a scene with glass, for photons and camera rays alike) in a scene without mirrors or glass,
and follows :data:`UNBOUNDED_SPECULAR` events on both paths in one with them; max_depth d >=
blockhash's depth + 2 follows d - 2 (at most :data:`UNBOUNDED_SPECULAR`) on both; a smaller d
>= 3 follows d - 2 on either path and d = 2 is direct light alone, each with one warning; 0
and 1 are refused.  ``rr_depth``, ``hide_emitters`` (point and spot lights are never seen
directly) and ``samples_per_pass`` change no expected pixel and are accepted."""

from __future__ import annotations

from typing import TYPE_CHECKING

from blockhash.scene.mitsuba.xml_values import MitsubaWarning, XmlReader
from blockhash.scene.model import DIELECTRIC_MAX_BOUNCES, MAX_BOUNCES

if TYPE_CHECKING:
    from blockhash.scene.mitsuba.sensor import Render

INTEGRATORS = ("path", "ptracer", "direct")
#: Surface events an indirect photon may meet under Mitsuba's unbounded ``max_depth`` (-1):
#: Russian roulette ends its path long before (a survival of 0.75 an event leaves 10^-8 of
#: the photons by the 64th).
UNBOUNDED_EVENTS = 64
#: Specular events a photon and a camera ray follow in a scene with mirrors or glass under an
#: unbounded (or deep) ``max_depth``: light between mirrors (the gold material preview's
#: hollows lost a quarter of some pixels at blockhash's own 4) and light trapped in glass by
#: total internal reflection goes on past blockhash's own 8 (its documentation's water and
#: diamond previews rendered 0.914 and 0.885 of Mitsuba's flux at 8, BENCHMARKS.md); a
#: camera branch still ends once its weight falls below
#: :data:`blockhash.frame.shading.BRANCH_CUTOFF`.
UNBOUNDED_SPECULAR = 128

#: Integrators that wrap one other and add what blockhash's layers do not hold, with what
#: blockhash renders of them.
WRAPPERS = {"moment": "its second moment (a variance estimate) is not rendered: blockhash renders "
                      "the integrator inside, the pixel means",
            "stokes": "the Stokes vector of polarised light is not rendered: blockhash renders "
                      "the integrator inside, intensity only (Stokes component s0)"}


def integrator(r: XmlReader, el) -> tuple[int | None, object]:
    """(max_depth or None, the element) of an ``<integrator>``; a ``moment`` or ``stokes``
    wrapper gives the one inside's, with one :class:`MitsubaWarning` saying what differs."""
    kind = el.get("type")
    if kind in WRAPPERS:
        import warnings

        r.props(el, {}, children=("integrator",))
        inner = [k for k in el if isinstance(k.tag, str)]
        if len(inner) != 1:
            r.fail(el, f"expected exactly one <integrator> inside the {kind} integrator")
        warnings.warn(f"{r.where(el)}: <integrator type=\"{kind}\">: {WRAPPERS[kind]}",
                      MitsubaWarning, stacklevel=2)
        return integrator(r, inner[0])
    if kind not in INTEGRATORS:
        r.fail(el, f"unsupported integrator; supported: {', '.join(INTEGRATORS)} (blockhash "
               "renders direct light and caustics by photon mapping; their max_depth is read)")
    allowed = {"max_depth": ("integer",), "rr_depth": ("integer",),
               "hide_emitters": ("boolean",)}
    if kind == "ptracer":
        allowed["samples_per_pass"] = ("integer",)
    if kind == "direct":  # its sample counts change the noise only
        allowed = {name: ("integer",) for name in ("shading_samples", "emitter_samples",
                                                    "bsdf_samples")} | {"hide_emitters": ("boolean",)}
    p = r.props(el, allowed)
    depth = p.get("max_depth")
    if depth is not None and depth < -1:
        r.fail(el, f"max_depth {depth}: must be -1 (unbounded) or >= 0 (as in Mitsuba)")
    if p.get("rr_depth", 1) < 1:
        r.fail(el, f"rr_depth {p['rr_depth']} must be > 0 (as in Mitsuba)")
    return depth, el


#: What blockhash renders otherwise than Mitsuba at a small max_depth or with its direct
#: integrator (the warnings' text).
DIRECT_DIFFERS = ("blockhash renders the direct light alone, as Mitsuba: no photons, so no caustic "
                  "and no light between diffuse surfaces, and nothing seen in mirrors and glass "
                  "but the lights")
DEPTH_DIFFERS = ("blockhash follows at most {events} specular event(s) on the photons' paths and "
                 "as many on the camera's, each on its own, where Mitsuba's max_depth {depth} "
                 "bounds the whole path: a caustic seen in a mirror or through glass is in "
                 "blockhash's image and not in Mitsuba's")


def depths(r: XmlReader, render: Render, glass: bool,
           specular: bool = False) -> tuple[int | None, int | None, bool]:
    """(specular events per photon, specular events per camera ray, direct light only) for the
    integrator (None: the scene's defaults): ``direct``, or ``max_depth`` 2, is direct light
    alone; a ``max_depth`` d below blockhash's own depth + 2 follows d - 2 specular events on
    either path; each of these with one :class:`MitsubaWarning` saying what differs.  In a
    scene with mirrors or glass (``specular``), an unbounded depth follows
    :data:`UNBOUNDED_SPECULAR` events, and a deeper one d - 2, at most as many."""
    import warnings

    if render.integrator is not None and render.integrator.get("type") == "direct":
        warnings.warn(f"{r.where(render.integrator)}: <integrator type=\"direct\">: {DIRECT_DIFFERS}",
                      MitsubaWarning, stacklevel=3)
        return None, 0, True
    d = render.max_depth
    if d is None or d == -1:
        return (UNBOUNDED_SPECULAR, UNBOUNDED_SPECULAR, False) if specular or glass \
            else (None, None, False)
    if d < 2:
        r.fail(render.integrator, f"max_depth {d} renders {'nothing' if d == 0 else 'only the emitters the camera sees'}; "
               "blockhash renders light on surfaces: give max_depth -1 or >= 2")
    events = DIELECTRIC_MAX_BOUNCES if glass else MAX_BOUNCES
    if d == 2:
        warnings.warn(f"{r.where(render.integrator)}: max_depth 2: {DIRECT_DIFFERS}", MitsubaWarning,
                      stacklevel=3)
        return None, 0, True
    if d < events + 2:
        warnings.warn(f"{r.where(render.integrator)}: max_depth {d}: "
                      + DEPTH_DIFFERS.format(events=d - 2, depth=d), MitsubaWarning, stacklevel=3)
        return d - 2, d - 2, False
    if specular or glass:
        deep = min(d - 2, UNBOUNDED_SPECULAR)
        return deep, deep, False
    return d - 2, None, False


__all__ = ["integrator", "depths", "INTEGRATORS", "UNBOUNDED_EVENTS", "UNBOUNDED_SPECULAR"]
