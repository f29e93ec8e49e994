"""Checked scene values: numbers, vectors, colours and choices with key paths in errors.

Every check raises ``FieldError`` naming the key path (``objects[1].material``),
what was expected and what was received; :mod:`blockhash.scene.model` adds the file
name.  Used by the scene dataclasses (built in code or from TOML) and the loader.
"""

from __future__ import annotations

import math
from contextlib import contextmanager

import numpy as np

from blockhash.errors import InputError


class FieldError(InputError):
    """An error at a key path; the loader adds the file name and the table path."""

    def __init__(self, key: str, detail: str, owner: str = ""):
        self.key, self.detail = key, detail
        super().__init__(f"{owner + '.' if owner else ''}{key}: {detail}")


@contextmanager
def under(prefix: str):
    """Prefix the key path of any FieldError raised inside with ``prefix``."""
    try:
        yield
    except FieldError as exc:
        key = f"{prefix}.{exc.key}" if exc.key else prefix
        raise FieldError(key.replace(".[", "["), exc.detail) from None


@contextmanager
def owned(owner: str):
    """Name the class in errors of a dataclass built in code (not from a file)."""
    try:
        yield
    except FieldError as exc:
        raise FieldError(exc.key, exc.detail, owner) from None


def kind(value) -> str:
    """TOML's name for a value's type."""
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "float"
    if isinstance(value, str):
        return "string"
    if isinstance(value, dict):
        return "table"
    if isinstance(value, (list, tuple, np.ndarray)):
        return "array"
    return type(value).__name__


def got(value) -> str:
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, np.ndarray):
        value = value.tolist()
    return f"{value!r} ({kind(value)})"


# --------------------------------------------------------------------------- value checks

def number(value, key: str, *, lo: float | None = None, hi: float | None = None,
            lo_open: bool = False, hi_open: bool = False, hint: str = "") -> float:
    """A finite real (TOML integer or float) within the given bounds."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise FieldError(key, f"expected a number; got {got(value)}" + (f"; {hint}" if hint else ""))
    x = float(value)
    if not math.isfinite(x):
        raise FieldError(key, f"expected a finite number; got {x!r}" + (f"; {hint}" if hint else ""))
    bad = (lo is not None and (x <= lo if lo_open else x < lo)) or \
          (hi is not None and (x >= hi if hi_open else x > hi))
    if bad:
        left = "-inf" if lo is None else f"{lo:g}"
        right = "inf" if hi is None else f"{hi:g}"
        span = f"{'(' if lo_open or lo is None else '['}{left}, {right}{')' if hi_open or hi is None else ']'}"
        raise FieldError(key, f"expected a number in {span}; got {x!r}" + (f"; {hint}" if hint else ""))
    return x


def integer(value, key: str, *, lo: int, hi: int | None = None, hint: str = "") -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        more = f"; write it without a decimal point, e.g. {int(value)}" \
            if isinstance(value, float) and math.isfinite(value) and value.is_integer() else ""
        raise FieldError(key, f"expected an integer; got {got(value)}{more}")
    v = int(value)
    if v < lo or (hi is not None and v > hi):
        span = f">= {lo:,}" if hi is None else f"in {lo:,} .. {hi:,}"
        raise FieldError(key, f"expected an integer {span}; got {v:,}" + (f"; {hint}" if hint else ""))
    return v


def readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, dtype=np.float64)
    arr.setflags(write=False)
    return arr


def vector(value, key: str, *, unit: str = "metres") -> np.ndarray:
    """Three finite numbers [x, y, z]."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise FieldError(key, f"expected an array of 3 numbers [x, y, z] ({unit}); got {got(value)}")
    return readonly([number(v, f"{key}[{i}]") for i, v in enumerate(value)])


def rgb(value, key: str, *, hi: float | None = None, what: str) -> np.ndarray:
    """A number (grey / white) or [r, g, b], each >= 0 (and <= hi)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        if len(value) != 3:
            raise FieldError(key, f"expected {what} as a number or [r, g, b]; got {got(value)}")
        items = [(v, f"{key}[{i}]") for i, v in enumerate(value)]
    else:
        items = [(value, key)] * 3
    return readonly([number(v, k, lo=0.0, hi=hi, hint=f"{what} must be in "
                              f"[0, {'inf' if hi is None else f'{hi:g}'}]") for v, k in items])


def string(value, key: str, *, what: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise FieldError(key, f"expected {what} (a non-empty string); got {got(value)}")
    return value


def boolean(value, key: str) -> bool:
    if not isinstance(value, bool):
        raise FieldError(key, f"expected true or false; got {got(value)}")
    return value


def choice(value, key: str, choices) -> str:
    if value not in choices:
        raise FieldError(key, f"expected one of {', '.join(map(repr, choices))}; got {got(value)}")
    return value


def fmt(v) -> str:
    return "(" + ", ".join(f"{float(x):g}" for x in np.asarray(v).reshape(-1)) + ")"


def check_mesh(mesh, key: str) -> None:
    """A mesh with at least one triangle and finite vertices, or an error naming ``key``."""
    if len(mesh.faces) == 0:
        raise FieldError(key, "the mesh is empty (0 triangles); expected at least one triangle")
    if not np.isfinite(mesh.vertices).all():
        raise FieldError(key, "the mesh has NaN or infinite vertex coordinates; fix the mesh")
