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
    and any other keyword given.
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
            return names.get(key, f"{key}=")
    return template.format_map(Fields(values))


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
