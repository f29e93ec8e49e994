"""The camera's pixel filter: how much each sample counts in the pixels around it.

A pixel's value is the weighted mean ``sum_i w(c - x_i) L_i / sum_i w(c - x_i)`` of the
samples ``x_i`` near its centre ``c`` (film coordinates in pixels), the weight separable,
``w(d) = f(d_x) f(d_y)``, as Mitsuba 3's film develops its ``rfilter``:

- ``box``: ``f = 1`` inside the sample's own pixel: the pixel mean (blockhash's default for its
  own scenes, and what its light tracer's reference computes);
- ``tent``: ``f(d) = max(0, 1 - |d| / radius)`` (Mitsuba's default radius 1);
- ``gaussian``: ``f(d) = max(0, exp(-d^2 / (2 stddev^2)) - exp(-8))``, cut at 4 standard
  deviations (Mitsuba's default stddev 0.5, and Mitsuba's filter where a film names none).

:mod:`blockhash.frame.film_filter` applies it to a pass's samples and to the photons splatted
straight into pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from blockhash.scene.values import FieldError as _FieldError
from blockhash.scene.values import number as _number
from blockhash.scene.values import owned as _owned

#: The filters, each with its one parameter (None: none) and that parameter's default.
FILTERS = {"box": (None, None), "tent": ("radius", 1.0), "gaussian": ("stddev", 0.5)}
#: A Gaussian is cut at this many standard deviations (its radius), as Mitsuba's.
GAUSSIAN_CUT = 4.0
#: Least reach of a filter, in pixels: every point of a pixel must weigh in its own pixel,
#: else a pixel whose samples all fall outside the filter's support would have no weight.
MIN_RADIUS = 0.5


@dataclass(frozen=True)
class PixelFilter:
    """A pixel filter (module docstring): ``kind`` one of :data:`FILTERS`; ``width`` the tent's
    radius or the Gaussian's standard deviation in pixels (None: Mitsuba's default)."""

    kind: str = "box"
    width: float | None = None

    def __post_init__(self):
        with _owned("PixelFilter"):
            if self.kind not in FILTERS:
                raise _FieldError("kind", f"expected one of {', '.join(map(repr, FILTERS))}; got "
                                  f"{self.kind!r}")
            name, default = FILTERS[self.kind]
            if name is None:
                if self.width is not None:
                    raise _FieldError("width", "a box filter takes no width; leave it out")
                return
            width = default if self.width is None else self.width
            lo = MIN_RADIUS / (GAUSSIAN_CUT if self.kind == "gaussian" else 1.0)
            width = _number(width, name, lo=lo, lo_open=True, hi=64.0,
                            hint=f"give the {self.kind} filter's {name} in pixels, above {lo:g} "
                                 f"(at least half a pixel of reach) and at most 64; default {default:g}")
            object.__setattr__(self, "width", width)

    @property
    def is_box(self) -> bool:
        return self.kind == "box"

    @property
    def radius(self) -> float:
        """How far a sample reaches, in pixels (0.5 for the box: its own pixel)."""
        if self.kind == "box":
            return 0.5
        return self.width * (GAUSSIAN_CUT if self.kind == "gaussian" else 1.0)

    def weight(self, d) -> np.ndarray:
        """f(d) of one axis (module docstring), float64, for offsets ``d`` in pixels."""
        d = np.abs(np.asarray(d, dtype=np.float64))
        if self.kind == "box":
            return (d <= 0.5).astype(np.float64)
        if self.kind == "tent":
            return np.maximum(0.0, 1.0 - d / self.width)
        alpha = -0.5 / (self.width * self.width)
        return np.where(d < self.radius, np.maximum(0.0, np.exp(alpha * d * d)
                                                    - math.exp(alpha * self.radius ** 2)), 0.0)

    def to_dict(self) -> dict:
        name = FILTERS[self.kind][0]
        return {"kind": self.kind} if name is None else {"kind": self.kind, name: self.width}


#: The pixel mean.
BOX = PixelFilter()


def pixel_filter(value, key: str = "filter") -> PixelFilter:
    """A :class:`PixelFilter` from a scene file's value: a kind (``"tent"``) or a table
    (``{kind = "gaussian", stddev = 0.7}``)."""
    if isinstance(value, PixelFilter):
        return value
    if isinstance(value, str):
        value = {"kind": value}
    if not isinstance(value, dict) or "kind" not in value:
        raise _FieldError(key, f"expected a filter kind ({', '.join(map(repr, FILTERS))}) or a "
                          "table with kind and its width, e.g. {kind = \"tent\", radius = 1.0}; "
                          f"got {value!r}")
    kind = value["kind"]
    name = FILTERS.get(kind, (None, None))[0] if isinstance(kind, str) else None
    extra = sorted(set(value) - {"kind"} - ({name} if name else set()))
    try:
        if extra:
            raise _FieldError(extra[0], f"unknown key for a {kind!r} filter; expected "
                              + (f"{name!r}" if name else "none besides kind"))
        return PixelFilter(kind, value.get(name) if name else None)
    except _FieldError as exc:
        raise _FieldError(f"{key}.{exc.key}", exc.detail) from None
