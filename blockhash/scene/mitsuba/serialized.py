"""Mitsuba's ``serialized`` mesh files, read as Mitsuba 3 reads them (its ``serialized`` shape
plugin documents the format): a little-endian ``uint16`` identifier ``0x041C`` and version (3 or
4), then per mesh a zlib stream of ``uint32`` flags (``0x0001`` vertex normals, ``0x0002``
texture coordinates, ``0x0008`` vertex colours, ``0x0010`` face normals, ``0x2000`` double
precision), in version 4 the mesh's name (a null-terminated string), ``uint64`` vertex and
triangle counts, the positions, the normals, texture coordinates and colours where the flags
say, and ``uint32`` triangle indices.  A file of several meshes concatenates them, each with its
own header, and ends with the offset of each (``uint64``; ``uint32`` in version 3) and their
count (``uint32``): ``shape_index`` picks one.  Texture coordinates are read for a checkerboard
(:mod:`.textures`); colours are skipped.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from blockhash.errors import InputError

MAGIC = 0x041C
VERSIONS = (3, 4)
HAS_NORMALS, HAS_TEXCOORDS, HAS_COLORS, FACE_NORMALS, DOUBLE = 0x0001, 0x0002, 0x0008, 0x0010, 0x2000


def read_serialized(path: Path, shape_index: int = 0):
    """(vertices (n, 3), faces (m, 3), the file's vertex normals or None, face normals flag,
    texture coordinates (n, 2) or None) of mesh ``shape_index`` of the ``serialized`` file at
    ``path``; an InputError naming the file and what is wrong with it."""
    data = Path(path).read_bytes()

    def bad(what: str):
        raise InputError(f"{path}: {what}; expected a Mitsuba .serialized mesh file")

    if len(data) < 8:
        bad("too short for a serialized file")
    magic, version = struct.unpack_from("<HH", data, 0)
    if magic != MAGIC:
        bad(f"its identifier is 0x{magic:04X}, not 0x{MAGIC:04X}")
    if version not in VERSIONS:
        bad(f"version {version} is not one Mitsuba reads (3 or 4)")
    start = 4
    if shape_index:
        (count,) = struct.unpack_from("<I", data, len(data) - 4)
        if not 0 <= shape_index < count:
            raise InputError(f"{path}: shape_index {shape_index} is outside the file's "
                             f"{count} mesh(es) (0..{count - 1}); give one of those")
        width = 8 if version == 4 else 4
        (offset,) = struct.unpack_from("<Q" if width == 8 else "<I", data,
                                       len(data) - 4 - width * (count - shape_index))
        start = offset + 4  # past that mesh's own header
    try:
        body = zlib.decompressobj().decompress(data[start:])
    except zlib.error as exc:
        bad(f"its compressed mesh data cannot be read ({exc})")
    at = 0

    def take(fmt: str):
        nonlocal at
        size = struct.calcsize(fmt)
        if at + size > len(body):
            bad("it ends inside a mesh")
        values = struct.unpack_from(fmt, body, at)
        at += size
        return values

    def array(dtype, count: int, columns: int):
        nonlocal at
        size = np.dtype(dtype).itemsize * count * columns
        if at + size > len(body):
            bad("it ends inside a mesh's arrays")
        out = np.frombuffer(body, dtype=dtype, count=count * columns, offset=at).reshape(count, columns)
        at += size
        return out

    (flags,) = take("<I")
    if version == 4:
        end = body.find(b"\0", at)
        if end < 0:
            bad("its mesh name is not terminated")
        at = end + 1
    vertices, triangles = take("<QQ")
    real = "<f8" if flags & DOUBLE else "<f4"
    positions = array(real, vertices, 3).astype(np.float64)
    normals = array(real, vertices, 3).astype(np.float64) if flags & HAS_NORMALS else None
    uv = array(real, vertices, 2).astype(np.float64) if flags & HAS_TEXCOORDS else None
    if flags & HAS_COLORS:
        array(real, vertices, 3)
    faces = array("<u4", triangles, 3).astype(np.int64)
    return positions, faces, normals, bool(flags & FACE_NORMALS), uv
