"""Options of the caustic density estimate, and its per-photon weights (CPU side).

The caustic pass (:mod:`.caustic`, ``glsl/caustic_estimate.glsl``) estimates radiance at
a shading point x with normal n from the m <= k nearest photons found, nearest first,
``r`` the distance to the m-th (floored at the photon map's position error)::

    L = sum_i  w(d_i / r)  f_r(w_i, w_o)  Phi_i  /  (pi r^2)

over the photons i that count (below).  The choices, each an :class:`EstimateOptions`
field, measured against the light-traced reference in ``docs/radiance-estimate.md``:

``estimate`` : {'conserving', 'unbiased', 'paper'}
    ``paper`` sums all m photons (Jensen's estimate, paper section 1).  The m-th photon
    lies on the circle of radius r by construction, so for a uniform density the sum
    overestimates by m / (m - 1) (2 % at k = 50).  ``unbiased`` leaves the m-th out:
    given r, the other m - 1 photons are uniform in the disc, and the sum of m - 1 over
    pi r^2 is unbiased.  With a filter below the m-th photon's weight is 0 anyway, so
    the two agree (the filters are normalised for that).  Both spread light beside a
    caustic's fold lines and edges, where r grows away from the caustic: the image holds
    more than the photons' power (2.5 % on venus at 10^6 photons).
    ``conserving`` gives every photon a radius of its own, h_i, fixed before rendering
    (:mod:`.photon_radius`: the distance to its round(k - 2 sqrt(k))-th nearest other
    photon), and
    sums ``w(d_i / h_i) f_r Phi_i / (pi h_i^2)`` over the m found photons whose discs
    cover x (d_i < h_i).  Each photon's filter then integrates to its power over its
    surface (Silverman's sample-point estimator): the image keeps the photons' power.
``filter`` : {'none', 'cone', 'epanechnikov', 'silverman'}
    The weight w(t), t = d_i / r, each normalised so that its mean over the unit disc is
    1 (so uniform photons give the same estimate): ``none`` 1 (box); ``cone`` 3 (1 - t)
    (Jensen's cone filter with k = 1, divided by 1 - 2 / (3k)); ``epanechnikov``
    2 (1 - t^2); ``silverman`` 3 (1 - t^2)^2 (Silverman's second-order kernel, 1986).
    Filters weigh near photons more, which sharpens caustic edges and costs noise.
``normal_cos`` : float or None
    A photon counts only where its stored surface normal (paper Fig. 4) agrees with the
    shading normal: ``dot(n_p, n) >= normal_cos``.  Photons that landed on another
    surface inside the search sphere (a wall beside a floor, the neck above the chest)
    then do not brighten this one.  None turns the test off.  Independently of it a
    photon must arrive from the front, ``dot(w_i, n) > 0``, as before.
``disc`` : float or None
    Jensen's flattened neighbourhood: a photon counts only within ``disc * r`` of the
    tangent plane, ``|dot(p_i - x, n)| <= disc * r``.  None turns it off.

The radius r always comes from the m-th photon found, whether or not it counts: the
photons of other surfaces take part in the search (it is a sphere) and are only left
out of the sum.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from blockhash.errors import InputError

#: Estimate forms, numbered as glsl/caustic_estimate.glsl's CAUSTIC_ESTIMATE.
ESTIMATES = ("paper", "unbiased", "conserving")
#: Filters, numbered as glsl/caustic_estimate.glsl's CAUSTIC_FILTER.
FILTERS = ("none", "cone", "epanechnikov", "silverman")
#: The shader's value of a test that is off (any dot product of unit vectors is above it).
OFF = -2.0
#: Default threshold of the photon normal test: cos 60 degrees.  Photons of surfaces that
#: meet the receiver at 60 degrees or more (a wall on a floor: 90) are left out; the
#: receiver's own photons pass wherever its normal turns by less than 60 degrees across
#: the search disc (r / R < ~1 rad on a curve of radius R) plus the normals' polar-code
#: error (<= 0.8 degrees, paper Fig. 4).  0.9 (26 degrees) already drops a few of the
#: chest's own photons on Venus (docs/radiance-estimate.md).
NORMAL_COS = 0.5


@dataclass(frozen=True)
class EstimateOptions:
    """How the caustic pass turns found photons into radiance (module docstring).

    estimate : {'conserving', 'unbiased', 'paper'}
    filter : {'none', 'cone', 'epanechnikov', 'silverman'}
    normal_cos : float in [-1, 1] or None    photon normal test, None off
    disc : float >= 0 or None                 flattened neighbourhood, None off
    """

    estimate: str = "conserving"
    filter: str = "cone"
    normal_cos: float | None = NORMAL_COS
    disc: float | None = None

    @property
    def conserving(self) -> bool:
        """The power-conserving form (each photon's own radius), which the cover gather sums."""
        return self.estimate == "conserving"

    def __post_init__(self):
        if self.estimate not in ESTIMATES:
            raise InputError(f"estimate={self.estimate!r} is not known; choose one of "
                             f"{', '.join(ESTIMATES)}")
        if self.filter not in FILTERS:
            raise InputError(f"filter={self.filter!r} is not known; choose one of {', '.join(FILTERS)}")
        if self.normal_cos is not None:
            c = _real(self.normal_cos, "normal_cos")
            if not -1.0 <= c <= 1.0:
                raise InputError(f"normal_cos={c!r} must lie in [-1, 1] (a cosine); use None to "
                                 "turn the photon normal test off")
            object.__setattr__(self, "normal_cos", c)
        if self.disc is not None:
            t = _real(self.disc, "disc")
            if not t >= 0.0:
                raise InputError(f"disc={t!r} must be >= 0 (a fraction of the search radius); use "
                                 "None to turn the flattened neighbourhood off")
            object.__setattr__(self, "disc", t)

    @classmethod
    def of(cls, options=None, **changes) -> "EstimateOptions":
        """``options`` (None: the defaults) with keyword ``changes`` that are not None."""
        from dataclasses import replace

        base = cls() if options is None else options
        if not isinstance(base, cls):
            raise InputError(f"estimate options must be an EstimateOptions; got {type(base).__name__}")
        return replace(base, **{k: v for k, v in changes.items() if v is not None})

    @property
    def label(self) -> str:
        """Short name for tables: 'unbiased/none/n0.5'."""
        n = "off" if self.normal_cos is None else f"{self.normal_cos:g}"
        d = "" if self.disc is None else f"/disc{self.disc:g}"
        return f"{self.estimate}/{self.filter}/n{n}{d}"

    def defines(self) -> dict:
        """The #defines of glsl/caustic_estimate.glsl."""
        return {"CAUSTIC_ESTIMATE": ESTIMATES.index(self.estimate),
                "CAUSTIC_FILTER": FILTERS.index(self.filter)}

    def uniforms(self) -> dict:
        """The uniforms of glsl/caustic_estimate.glsl (OFF where a test is off)."""
        return {"caustic_normal_cos": OFF if self.normal_cos is None else self.normal_cos,
                "caustic_disc": OFF if self.disc is None else self.disc}


def _real(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"{name} must be a number or None; got {value!r}")
    v = float(value)
    if not np.isfinite(v):
        raise InputError(f"{name}={v!r} must be finite, or None to turn the test off")
    return v


def kernel(filter_name: str, t2: np.ndarray) -> np.ndarray:
    """w(t) of the module docstring from t^2 = (d / r)^2 (clipped to [0, 1]), any shape."""
    t2 = np.clip(t2, 0.0, 1.0)
    if filter_name == "none":
        return np.ones_like(t2)
    if filter_name == "cone":
        return 3.0 * (1.0 - np.sqrt(t2))
    if filter_name == "epanechnikov":
        return 2.0 * (1.0 - t2)
    if filter_name == "silverman":
        return 3.0 * (1.0 - t2) ** 2
    raise InputError(f"filter={filter_name!r} is not known; choose one of {', '.join(FILTERS)}")


def photon_weights(options: EstimateOptions, d2, r2, found, wi, n_photon, n_shading, offset,
                   own_r2=None):
    """(q, k) float64 weight of every found photon: filter times the tests (0: left out),
    such that the radiance is ``sum weight f_r Phi / (pi r2)``.

    d2 : (q, k) squared distances; r2 : (q,) squared radius; found : (q, k) bool (found
    photons first); wi : (q, k, 3) unit directions toward where each photon came from;
    n_photon : (q, k, 3) stored normals; n_shading : (q, 3); offset : (q, k, 3) photon
    position minus the shading point; own_r2 : (q, k) each found photon's own squared
    radius (:mod:`.photon_radius`), needed by the conserving estimate only: its weight is
    ``w(d / h) r2 / h^2``.
    """
    q, k = found.shape
    if options.conserving:
        if own_r2 is None:
            raise InputError("the conserving estimate needs each photon's own radius; pass "
                             "own_r2 (blockhash.frame.photon_radius.own_radii2)")
        with np.errstate(divide="ignore", invalid="ignore"):
            t2 = np.where(found, d2 / own_r2, np.inf)
            w = np.where(t2 < 1.0, kernel(options.filter, t2) * (r2[:, None] / own_r2), 0.0)
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            t2 = np.where(r2[:, None] > 0, d2 / r2[:, None], 1.0)
        w = kernel(options.filter, t2)
    keep = found & (np.einsum("qkc,qc->qk", wi, n_shading) > 0)
    if options.estimate == "unbiased":
        m = found.sum(axis=1)
        keep &= np.arange(k)[None, :] < (m - 1)[:, None]
    if options.normal_cos is not None:
        keep &= np.einsum("qkc,qc->qk", n_photon, n_shading) >= options.normal_cos
    if options.disc is not None:
        height = np.abs(np.einsum("qkc,qc->qk", offset, n_shading))
        keep &= height <= options.disc * np.sqrt(r2)[:, None]
    return np.where(keep, w, 0.0)
