"""Where the photon stages run, chosen in one place: the ``device`` of a render (or the
environment variable :data:`ENV`, read when none is given).

* ``cpu``: Dr.Jit's LLVM backend (Mitsuba's ``llvm_ad_rgb``), needs the ``mitsuba`` extra and
  an LLVM >= 16 shared library;
* ``gpu``: Dr.Jit's CUDA backend (``cuda_ad_rgb``, OptiX rays), needs an NVIDIA driver;
* ``host``: the numpy, numba and embree tracer (:mod:`blockhash.photons.paths`), which the
  tests keep as the kernels' oracle;
* ``auto``: ``gpu`` where it starts, else ``cpu``, else ``host``, with one line on stderr
  (once a process) saying what was missing.

A render's photons are the same in any process on one device; the devices agree in
distribution (power per receiver within noise), not photon by photon.
"""

from __future__ import annotations

import functools
import glob
import os
import re
import sys
from dataclasses import dataclass

from blockhash.errors import InputError

#: The devices a render may ask for.
DEVICES = ("auto", "cpu", "gpu", "host")
#: The environment variable read when a render names no device.
ENV = "BLOCKHASH_DEVICE"
#: The device of a render that names none, with the environment variable unset.
DEFAULT = "auto"
#: Mitsuba's variant of each Dr.Jit device.
VARIANTS = {"cpu": "llvm_ad_rgb", "gpu": "cuda_ad_rgb"}


@dataclass(frozen=True)
class Device:
    """A resolved device: ``name`` (``cpu``, ``gpu`` or ``host``), Mitsuba's ``variant`` of its
    kernels (None on the host) and, for ``auto``, why it is not the GPU (``note``)."""

    name: str
    variant: str | None = None
    note: str = ""

    @property
    def jit(self) -> bool:
        """The photon stages run as Dr.Jit kernels."""
        return self.variant is not None

    def modules(self):
        """``(mitsuba, drjit)`` with this device's variant set (Mitsuba's variant is global
        to a process: the kernels set theirs before they build or run)."""
        import mitsuba as mi

        if mi.variant() != self.variant:
            mi.set_variant(self.variant)
        import drjit as dr

        return mi, dr


def device_name(device: str | None = None) -> str:
    """``device``, or the environment's (:data:`ENV`), or :data:`DEFAULT`, checked."""
    name = device if device is not None else (os.environ.get(ENV) or DEFAULT)
    if not isinstance(name, str) or name.strip().lower() not in DEVICES:
        where = f"the environment variable {ENV}" if device is None else "device"
        raise InputError(f"{where} is {name!r}; expected one of {', '.join(DEVICES)} "
                         "(auto: the GPU where there is one, else the CPU)")
    return name.strip().lower()


def resolve(device: str | None = None) -> Device:
    """The :class:`Device` that ``device`` (module docstring) names here.  ``cpu`` or ``gpu``
    that cannot start raises :class:`InputError` naming what is missing and the way out."""
    return _resolve(device_name(device))


@functools.lru_cache(maxsize=None)
def _resolve(name: str) -> Device:
    if name == "host":
        return Device("host")
    if name != "auto":
        reason = _missing(name)
        if reason:
            raise InputError(f"device {name!r}: {reason}; {_WAY_OUT[name]}")
        return Device(name, VARIANTS[name])
    gpu = _missing("gpu")
    if not gpu:
        return Device("gpu", VARIANTS["gpu"])
    cpu = _missing("cpu")
    if not cpu:
        note = f"no GPU ({gpu}): the photon kernels run on the CPU (Dr.Jit LLVM)"
        print(f"blockhash: {note}", file=sys.stderr)
        return Device("cpu", VARIANTS["cpu"], note)
    note = (f"no Dr.Jit device ({cpu}): the photons are traced on the host (numba and embree), "
            f"{_WAY_OUT['cpu']}")
    print(f"blockhash: {note}", file=sys.stderr)
    return Device("host", None, note)


_WAY_OUT = {
    "cpu": ("install the extra (pip install 'blockhash[mitsuba]') and an LLVM >= 16 shared "
            "library (apt-get install libllvm19, or DRJIT_LIBLLVM_PATH naming one), or use "
            "device 'host'"),
    "gpu": "run on a machine with an NVIDIA GPU and its driver, or use device 'cpu' or 'auto'",
}


#: Where a system LLVM is looked for when DRJIT_LIBLLVM_PATH is unset.
LLVM_GLOBS = ("/usr/lib/x86_64-linux-gnu/libLLVM*.so*", "/usr/lib/aarch64-linux-gnu/libLLVM*.so*",
              "/usr/lib/llvm-*/lib/libLLVM*.so*", "/usr/lib64/libLLVM*.so*",
              "/usr/local/lib/libLLVM*.so*")
#: The oldest LLVM Dr.Jit's code generation works with here (LLVM 15 fails to select).
MIN_LLVM = 16


def llvm_library() -> str | None:
    """The newest system LLVM shared library of version :data:`MIN_LLVM` or later, if any."""
    best = None
    for pattern in LLVM_GLOBS:
        for path in glob.glob(pattern):
            m = re.search(r"libLLVM[-.]?(\d+)", os.path.basename(path)) or \
                re.search(r"libLLVM\.so\.(\d+)", os.path.basename(path))
            if m and int(m.group(1)) >= MIN_LLVM and (best is None or int(m.group(1)) > best[0]):
                best = (int(m.group(1)), path)
    return best[1] if best else None


def find_llvm() -> None:
    """Point Dr.Jit at :func:`llvm_library` (``DRJIT_LIBLLVM_PATH``) unless it is set: before
    drjit is first imported, which reads it."""
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        lib = llvm_library()
        if lib:
            os.environ["DRJIT_LIBLLVM_PATH"] = lib


def _missing(name: str) -> str:
    """Why Dr.Jit's ``name`` device cannot run here ('' when it can)."""
    find_llvm()
    try:
        import mitsuba as mi
    except ImportError as exc:
        return f"the mitsuba package is not installed ({exc})"
    variant = VARIANTS[name]
    if variant not in mi.variants():
        return f"this Mitsuba build has no {variant} variant"
    try:
        import drjit as dr

        backend = dr.JitBackend.CUDA if name == "gpu" else dr.JitBackend.LLVM
        if not dr.has_backend(backend):
            return ("Dr.Jit found no CUDA driver" if name == "gpu" else
                    "Dr.Jit found no LLVM shared library (>= 16)")
        mi.set_variant(variant)
        dr.eval(mi.Float(1.0) + 1.0)
    except (ImportError, RuntimeError, AttributeError) as exc:
        return f"Dr.Jit's {variant} does not start ({str(exc).splitlines()[0] if str(exc) else exc})"
    return ""
