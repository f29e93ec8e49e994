"""Checks on user input shared by every module.

Each check raises an :class:`~blockhash.errors.InputError` (or
:class:`~blockhash.errors.InputTypeError`) naming the parameter, what was
expected, what was received and the way out.  Nothing is clamped or dropped.
"""

from __future__ import annotations

import numbers
import os
from pathlib import Path

import numpy as np

from blockhash.errors import InputError, InputTypeError, NonFiniteError


def as_points(value, name: str, *, dtype=np.float64, allow_empty: bool = True,
              finite: bool = True) -> np.ndarray:
    """Return ``value`` as a C-contiguous ``(n, 3)`` array of ``dtype``.

    Rejects non-numeric dtypes, other shapes, and (with ``finite``) NaN or
    infinite coordinates, naming the first offending row.
    """
    arr = np.asarray(value)
    if arr.dtype.kind not in "fiu":
        raise InputTypeError(
            f"{name} must be a real numeric array of shape (n, 3); got dtype {arr.dtype}. "
            "Convert it with np.asarray(..., dtype=np.float32)")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise InputError(
            f"{name} must have shape (n, 3); got shape {arr.shape}. "
            "Pass one row of x, y, z per point (reshape(-1, 3) for a flat array)")
    if not allow_empty and arr.shape[0] == 0:
        raise InputError(f"{name} is empty; at least one point is needed")
    arr = np.ascontiguousarray(arr, dtype=dtype)
    if finite:
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.argwhere(bad.any(axis=1))[0, 0])
            raise InputError(
                f"{name}[{i}]={arr[i].tolist()} is not finite ({int(bad.any(axis=1).sum())} "
                f"row(s) with NaN or inf); remove or fix those points before building")
    return arr


def as_int(value, name: str, *, minimum: int | None = None, maximum: int | None = None,
           hint: str = "") -> int:
    """Return ``value`` as a Python int in ``[minimum, maximum]``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if isinstance(value, numbers.Real) and float(value).is_integer():
            value = int(value)
        else:
            raise InputTypeError(f"{name} must be an integer; got {value!r} ({type(value).__name__})")
    value = int(value)
    if minimum is not None and value < minimum or maximum is not None and value > maximum:
        lo = "-inf" if minimum is None else f"{minimum:,}"
        hi = "inf" if maximum is None else f"{maximum:,}"
        raise InputError(f"{name}={value:,} is out of range; allowed {lo} <= {name} <= {hi}"
                         + (f"; {hint}" if hint else ""))
    return value


#: What ``indirect=True`` and ``False`` do, for the one message that refuses anything else.
INDIRECT = ("render the light between diffuse surfaces where the scene has it", "leave it out")


def as_flag(value, name: str, meaning: tuple[str, str]) -> bool:
    """``value`` if it is a bool; else InputError naming ``name`` and what True and False do
    (``meaning``)."""
    if not isinstance(value, bool):
        raise InputError(f"{name}={value!r}: expected True ({meaning[0]}) or False ({meaning[1]})")
    return value


def old_keywords(call: str, given: dict, known: tuple, instead: str) -> None:
    """Keywords a call still takes for one release: TypeError for any not in ``known``,
    else a DeprecationWarning naming ``instead``, the form to use (warned at the caller's
    caller)."""
    import warnings

    unknown = sorted(set(given) - set(known))
    if unknown:
        raise TypeError(f"{call}() got unexpected keyword arguments {unknown}")
    if given:
        warnings.warn(f"{call}({', '.join(f'{n}=' for n in given)}) is deprecated: {instead}",
                      DeprecationWarning, stacklevel=3)


def writable_path(path, flag: str) -> Path:
    """``path`` (a Path) if a file can be written there, else an InputError naming ``flag``
    (checked before long work, so that a typo does not cost a render)."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise InputError(f"{flag} {path}: is a directory; give a file name such as {path / 'out.exr'}")
    if not folder.is_dir():
        raise InputError(f"{flag} {path}: the folder {folder} does not exist; create it or give "
                         "another path")
    if not os.access(folder, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise InputError(f"{flag} {path}: not writable (permission denied); give a writable path")
    return path


def finite_image(image, layer: str, source: str, way_out: str) -> None:
    """Raise :class:`~blockhash.errors.NonFiniteError` if the (h, w, c) ``image`` holds NaN or
    infinity, naming the ``layer``, its ``source`` (a pass and its process, a file), how many
    pixels and the first pixel's coordinates (x right, y down from the top left)."""
    bad = ~np.isfinite(np.asarray(image))
    if bad.ndim == 3:
        bad = bad.any(axis=2)
    if not bad.any():
        return
    y, x = (int(v) for v in np.argwhere(bad)[0])
    count = int(bad.sum())
    raise NonFiniteError(f"{source}: the {layer} layer has {count:,} non-finite pixel"
                         f"{'s' if count > 1 else ''} (NaN or infinity) of {bad.size:,}, the first "
                         f"at x={x}, y={y}; {way_out}")
