"""An OSMesa OpenGL context that moderngl can use (``moderngl.init_context``).

glcontext has no OSMesa backend, so this module creates a core-profile context
with ``OSMesaCreateContextAttribs`` over a small offscreen buffer and hands
moderngl a loader that resolves functions with ``OSMesaGetProcAddress``.
Rendering goes to framebuffer objects; the OSMesa buffer only makes the
context current.  Needs Mesa's libOSMesa (Debian: ``libosmesa6``).
"""

from __future__ import annotations

import ctypes
import ctypes.util

OSMESA_FORMAT = 0x22
OSMESA_RGBA = 0x1908
OSMESA_DEPTH_BITS = 0x30
OSMESA_PROFILE = 0x33
OSMESA_CORE_PROFILE = 0x34
OSMESA_CONTEXT_MAJOR_VERSION = 0x36
OSMESA_CONTEXT_MINOR_VERSION = 0x37
GL_UNSIGNED_BYTE = 0x1401
#: Library names tried in order.
LIBRARIES = ("OSMesa", "libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so")


def load_library():
    """The OSMesa shared library, or None."""
    for name in LIBRARIES:
        path = ctypes.util.find_library(name) if "." not in name else name
        if not path:
            continue
        try:
            return ctypes.CDLL(path)
        except OSError:
            continue
    return None


class OSMesaLoader:
    """moderngl loader over an OSMesa context (``load_opengl_function``, enter/exit, release)."""

    def __init__(self, *, major: int = 4, minor: int = 5):
        lib = load_library()
        if lib is None:
            raise OSError("libOSMesa was not found (install Debian's libosmesa6)")
        self._lib = lib
        lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
        lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
        lib.OSMesaMakeCurrent.restype = ctypes.c_int
        lib.OSMesaMakeCurrent.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int,
                                          ctypes.c_int, ctypes.c_int]
        lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
        lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
        lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
        attribs = (ctypes.c_int * 11)(OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24,
                                      OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                                      OSMESA_CONTEXT_MAJOR_VERSION, major,
                                      OSMESA_CONTEXT_MINOR_VERSION, minor, 0)
        self._ctx = lib.OSMesaCreateContextAttribs(attribs, None)
        if not self._ctx:
            raise OSError(f"OSMesaCreateContextAttribs could not create a GL {major}.{minor} core context")
        self._buffer = (ctypes.c_ubyte * 4)()
        self._make_current()

    def _make_current(self):
        if not self._lib.OSMesaMakeCurrent(self._ctx, self._buffer, GL_UNSIGNED_BYTE, 1, 1):
            raise OSError("OSMesaMakeCurrent failed")

    def load_opengl_function(self, name: str) -> int:
        return self._lib.OSMesaGetProcAddress(name.encode()) or 0

    def __enter__(self):
        self._make_current()

    def __exit__(self, *exc):
        return None

    def release(self):
        if self._ctx:
            self._lib.OSMesaDestroyContext(self._ctx)
            self._ctx = None
