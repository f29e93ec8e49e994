"""Synthetic photon maps with the shading points a renderer would query them at.

The index must hold its accuracy on photon maps it was not tuned on, and a
renderer queries a photon map at its shading points: on the surfaces that
receive the photons, and on other diffuse surfaces that receive few or none.
Each :class:`PhotonMap` here therefore has two samplers:

``photons(n, rng)``
    photon positions, (n, 3) float64, denser where the caustic is bright;
``surfaces(n, rng)``
    points uniform over the map's diffuse surfaces (area measure), where
    shading points lie whatever the photon density.

:func:`queries` draws half of a query set from each (the first half from the
photons' distribution, the second from the surfaces).  As in
:mod:`.datasets`, the geometry of every map is fixed (``LAYOUT_SEED``), not
drawn from ``rng``.

The maps, by what they stress:

========== ==================================================================
uniform    a volume (no surface at all)
clustered  gaussian clusters in a volume
plane      one plane, uniform: a fully degenerate axis
caustic    :func:`.datasets.caustic_like`: a ring caustic on a floor, 3% on the ring's wall
tilted     a cardioid band, hot spots and a floor on y = 0, plus 10% of the
           photons on a tilted plane above it
room       the inner faces of a box (floor, walls, ceiling) with a caustic
           spot on the floor and one on a wall: photons on the box's faces,
           where every photon of a face shares one coordinate
sphere     a caustic band and a spot on a sphere (a curved receiver)
========== ==================================================================

and :func:`moved` / :func:`scaled` place any of them far from the origin or at
another scale.  The photon maps that ``scenes/ring.toml`` and
``scenes/venus.toml`` trace come from the renderer (``tools/eval_accuracy.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from blockhash.evaluate.datasets import LAYOUT_SEED, caustic_like, clustered, uniform
from blockhash.validate import as_int

Sampler = Callable[[int, np.random.Generator], np.ndarray]


@dataclass(frozen=True)
class PhotonMap:
    """A photon distribution and the surfaces its shading points lie on."""

    name: str
    photons: Sampler
    surfaces: Sampler

    def __repr__(self) -> str:
        return f"PhotonMap({self.name!r})"


def queries(photon_map: PhotonMap, m: int, rng: np.random.Generator) -> np.ndarray:
    """(m, 3) query points: ``m // 2`` from the photons' distribution, the rest on its surfaces."""
    m = as_int(m, "m", minimum=0)
    on = m // 2
    return np.concatenate([photon_map.photons(on, rng), photon_map.surfaces(m - on, rng)])


# --------------------------------------------------------------------------- building blocks

def _cardioid_band(n: int, rng, *, a: float, width: float) -> np.ndarray:
    """(n, 2) points on a cardioid band r = a (1 + cos t), denser toward its fold."""
    t = rng.vonmises(np.pi, 0.6, n)
    r = a * (1.0 + np.cos(t))
    xy = np.stack([r * np.cos(t) - 0.875 * a, r * np.sin(t)], axis=1)
    return xy + rng.normal(scale=width, size=(n, 2))


def _spots(n: int, rng, centres: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """(n, 2) gaussian hot spots of the given centres (s, 2) and widths (s,)."""
    which = rng.integers(0, len(centres), n)
    return centres[which] + rng.normal(size=(n, 2)) * spread[which, None]


def _on_floor(uv: np.ndarray, y: float = 0.0) -> np.ndarray:
    return np.stack([uv[:, 0], np.full(len(uv), y), uv[:, 1]], axis=1)


def _mix(rng, n: int, shares, parts) -> np.ndarray:
    """Draw ``n`` points, each part's count multinomial in ``shares``, in random order."""
    counts = rng.multinomial(n, np.asarray(shares) / np.sum(shares))
    p = np.concatenate([part(c) for part, c in zip(parts, counts)], axis=0)
    return p[rng.permutation(n)]


# --------------------------------------------------------------------------- the maps

def _uniform_cube(n, rng):
    return uniform(n, rng)


def _plane(n, rng):
    return _on_floor(rng.random((n, 2)) * 2.0 - 1.0)


def _caustic_surfaces(n, rng):
    """Uniform over the floor disc inside the ring and the ring's inner wall (by area)."""
    floor, wall = np.pi * 0.5 ** 2, 2.0 * np.pi * 0.5 * 0.3

    def disc(c):
        r = 0.5 * np.sqrt(rng.random(c))
        t = rng.random(c) * 2.0 * np.pi
        return _on_floor(np.stack([r * np.cos(t), r * np.sin(t)], axis=1))

    def ring_wall(c):
        t = rng.random(c) * 2.0 * np.pi
        return np.stack([0.5 * np.cos(t), 0.3 * rng.random(c), 0.5 * np.sin(t)], axis=1)

    return _mix(rng, n, (floor, wall), (disc, ring_wall))


#: The tilted plane of ``tilted``: through (0, 0.35, 0), normal tilted 30 degrees from +y
#: about x, spanning u, v in [-0.6, 0.6].
_TILT = np.deg2rad(30.0)
_TILT_ORIGIN = np.array([0.0, 0.35, 0.0])
_TILT_U = np.array([1.0, 0.0, 0.0])
_TILT_V = np.array([0.0, np.sin(_TILT), np.cos(_TILT)])


def _tilted_plane(c, rng):
    uv = rng.uniform(-0.6, 0.6, size=(c, 2))
    return _TILT_ORIGIN + uv[:, :1] * _TILT_U + uv[:, 1:] * _TILT_V


def _tilted(n, rng):
    layout = np.random.default_rng(LAYOUT_SEED + 1)
    centres = layout.uniform(-0.6, 0.6, size=(6, 2))
    spread = layout.uniform(0.01, 0.04, 6)
    return _mix(rng, n, (0.45, 0.2, 0.25, 0.10), (
        lambda c: _on_floor(_cardioid_band(c, rng, a=0.35, width=0.003)),
        lambda c: _on_floor(_spots(c, rng, centres, spread)),
        lambda c: _on_floor(rng.uniform(-1.0, 1.0, size=(c, 2))),
        lambda c: _tilted_plane(c, rng)))


def _tilted_surfaces(n, rng):
    return _mix(rng, n, (4.0, 1.44), (lambda c: _on_floor(rng.uniform(-1.0, 1.0, size=(c, 2))),
                                       lambda c: _tilted_plane(c, rng)))


#: The room of ``room``: [0, 4] x [0, 2.5] x [0, 3] metres.
_ROOM = np.array([4.0, 2.5, 3.0])


def _room_faces(c, rng):
    """Uniform over the six inner faces of the room, by area."""
    sx, sy, sz = _ROOM
    areas = np.array([sx * sz, sx * sz, sy * sz, sy * sz, sx * sy, sx * sy])
    face = rng.choice(6, size=c, p=areas / areas.sum())
    p = rng.random((c, 3)) * _ROOM
    axis = np.array([1, 1, 0, 0, 2, 2])[face]
    high = (face % 2 == 1)
    p[np.arange(c), axis] = np.where(high, _ROOM[axis], 0.0)
    return p


def _room(n, rng):
    sx, sy, sz = _ROOM

    def floor_spot(c):
        return _on_floor(_cardioid_band(c, rng, a=0.5, width=0.004) + [2.0, 1.5])

    def wall_spot(c):  # on the wall x = 0
        yz = rng.normal(size=(c, 2)) * [0.08, 0.15] + [1.2, 1.0]
        return np.stack([np.zeros(c), np.clip(yz[:, 0], 0, sy), np.clip(yz[:, 1], 0, sz)], axis=1)

    return _mix(rng, n, (0.5, 0.2, 0.3), (floor_spot, wall_spot, lambda c: _room_faces(c, rng)))


#: The sphere of ``sphere``: radius 0.5 m about (0, 0.5, 0).
_SPHERE_C, _SPHERE_R = np.array([0.0, 0.5, 0.0]), 0.5


def _on_sphere(theta, phi):
    st = np.sin(theta)
    return _SPHERE_C + _SPHERE_R * np.stack([st * np.cos(phi), np.cos(theta), st * np.sin(phi)], axis=1)


def _sphere_surface(c, rng):
    return _on_sphere(np.arccos(1.0 - 2.0 * rng.random(c)), rng.random(c) * 2.0 * np.pi)


def _sphere(n, rng):
    def band(c):  # a bright band around a latitude, denser toward phi = 0
        theta = 1.0 + rng.normal(scale=0.01, size=c)
        phi = rng.vonmises(0.0, 1.0, c)
        return _on_sphere(theta, phi)

    def spot(c):
        theta = np.abs(0.6 + rng.normal(scale=0.05, size=c))
        phi = 2.5 + rng.normal(scale=0.05, size=c)
        return _on_sphere(theta, phi)

    return _mix(rng, n, (0.6, 0.15, 0.25), (band, spot, lambda c: _sphere_surface(c, rng)))


MAPS = {m.name: m for m in (
    PhotonMap("uniform", _uniform_cube, _uniform_cube),
    PhotonMap("clustered", clustered, _uniform_cube),
    PhotonMap("plane", _plane, _plane),
    PhotonMap("caustic", caustic_like, _caustic_surfaces),
    PhotonMap("tilted", _tilted, _tilted_surfaces),
    PhotonMap("room", _room, lambda n, rng: _room_faces(n, rng)),
    PhotonMap("sphere", _sphere, lambda n, rng: _sphere_surface(n, rng)),
)}


def moved(photon_map: PhotonMap, offset) -> PhotonMap:
    """The same map translated by ``offset`` (3,) metres."""
    off = np.asarray(offset, dtype=np.float64)
    return PhotonMap(f"{photon_map.name}@{np.linalg.norm(off):.0e}m",
                     lambda n, rng: photon_map.photons(n, rng) + off,
                     lambda n, rng: photon_map.surfaces(n, rng) + off)


def scaled(photon_map: PhotonMap, factor: float) -> PhotonMap:
    """The same map scaled by ``factor`` about the origin."""
    f = float(factor)
    return PhotonMap(f"{photon_map.name}x{f:g}",
                     lambda n, rng: photon_map.photons(n, rng) * f,
                     lambda n, rng: photon_map.surfaces(n, rng) * f)


#: The extreme maps :func:`named` knows beside :data:`MAPS`.
EXTREMES = ("tilted@1e4", "roomx0.001")


def named(name: str) -> PhotonMap:
    """A map of :data:`MAPS` by name, or one of the extremes the accuracy study also reads:
    ``tilted@1e4`` (the tilted map 10^4 m from the origin, where float32 resolves about
    1 mm) and ``roomx0.001`` (the room scaled to millimetres)."""
    if name == "tilted@1e4":
        return moved(MAPS["tilted"], (1e4, 0.0, 0.0))
    if name == "roomx0.001":
        return scaled(MAPS["room"], 1e-3)
    if name not in MAPS:
        from blockhash.errors import InputError

        raise InputError(f"photon map {name!r} is not known; choose from "
                         f"{', '.join((*MAPS, *EXTREMES))}")
    return MAPS[name]
