"""Exceptions raised by blockhash.

Every error the package raises derives from :class:`BlockHashError`, and each
concrete class also derives from the builtin a caller would expect, so that
``except ValueError`` and ``except blockhash.BlockHashError`` both work.

Messages name the parameter (or file and key), what was expected, what was
received and the way out, e.g.::

    k=80 is larger than the number of photons N=64; use k <= 64 or trace more photons
"""

from __future__ import annotations


class BlockHashError(Exception):
    """Base class of every error raised by blockhash."""


class InputError(BlockHashError, ValueError):
    """A parameter, array or file had a value the package cannot accept."""


class InputTypeError(BlockHashError, TypeError):
    """An array or parameter had the wrong type or dtype."""


class CapacityError(BlockHashError, RuntimeError):
    """A data structure does not fit the limits it must live in."""


class GLUnavailableError(BlockHashError, RuntimeError):
    """No usable OpenGL context."""


class ShaderCompileError(BlockHashError, RuntimeError):
    """A shader of the library failed to compile or link: the message names the
    file:line of each compiler message, the variant and the active defines.
    Not a GLUnavailableError: the context works, the program does not."""
