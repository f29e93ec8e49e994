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
    """Base class of every error raised by blockhash.

    A message may name parameters by placeholder: ``InputError.about("{passes}{value}: ...",
    value=0)`` spells ``{passes}`` as the library's keyword, ``passes=``, so that ``str(exc)``
    reads ``passes=0: ...``; a front end that takes the same values under other names (the
    command line's flags, :data:`blockhash.cli.args.FLAGS`) prints
    ``exc.spelled({"passes": "--passes "})``: ``--passes 0: ...``.  Values fill ``{value}``
    and any other keyword given.  ``{name:bare}`` names the parameter alone (``max_flip``, or
    the flag ``--max-flip``), ``{name:on}`` a switch turned on (``drop_specular=True``, or the
    flag ``--drop-specular`` alone).
    """

    def __init__(self, message: str = "", *args, template: str | None = None,
                 values: dict | None = None):
        self.template, self.values = template, dict(values or {})
        super().__init__(message, *args)

    @classmethod
    def about(cls, template: str, **values) -> "BlockHashError":
        """An error whose message names parameters as ``{name}`` (class docstring)."""
        return cls(spell(template, values, {}), template=template, values=values)

    def spelled(self, names: dict) -> str:
        """The message with its parameters spelled as ``names`` says (the rest as the library
        spells them)."""
        if self.template is None:
            return str(self)
        return spell(self.template, self.values, names)


class InputError(BlockHashError, ValueError):
    """A parameter, array or file had a value the package cannot accept."""


def spell(template: str, values: dict, names: dict) -> str:
    """``template`` with its values filled and every other field spelled by ``names``, else
    as the keyword ``name=``."""

    class Fields(dict):
        def __missing__(self, key):
            return _Name(names[key], False) if key in names else _Name(f"{key}=", True)
    return template.format_map(Fields(values))


class _Name(str):
    """A parameter as a message spells it: as written before its value (``name=``, or a flag
    and a space), ``:bare`` alone, ``:on`` a switch turned on (``name=True``, or the flag)."""

    def __new__(cls, text: str, library: bool):
        name = super().__new__(cls, text)
        name.library = library
        return name

    def __format__(self, spec: str) -> str:
        if spec == "bare":
            return str(self).rstrip("= ")
        if spec == "on":
            return f"{self}True" if self.library else str(self).rstrip()
        return format(str(self), spec)


class NonFiniteError(BlockHashError, FloatingPointError):
    """An image layer holds NaN or infinity (a renderer's or a driver's fault, never written
    to a file): the message names the layer, where it came from, how many pixels and the
    first."""


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
