"""The GLSL library: locating it, splicing includes, emitting defines, compiling.

Shader files live in ``glsl/`` (shipped as the package ``blockhash.glsl``).
``#include "file"`` lines are spliced recursively with cycle detection; each
splice is followed by a ``#line`` directive that encodes the file in the line
number itself (``file_id * LINE_STRIDE + line``, with ``file_id`` also given as
the source-string number), because Mesa reports source string 0 whatever
``#line`` says.  A compiler message ``S:N(col)`` then maps back to ``file:line``.
Python never rewrites lines inside a shader file: every configurable value is a
``#define`` emitted after ``#version`` from one frozen dataclass.
"""

from __future__ import annotations

import itertools
import re
from contextlib import contextmanager
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path

from blockhash.errors import GLUnavailableError, InputError, ShaderCompileError
from blockhash.gl import strict

GLSL_VERSION = "#version 450 core"
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
#: Lines per file in the encoded ``#line`` numbers; no library file comes near it.
LINE_STRIDE = 100_000


def glsl_dir() -> Path:
    """The directory of the shader library: a checkout's ``glsl/`` beside this package
    when there is one (so every checkout, worktree or editable install compiles its own
    shaders), else the installed wheel's ``blockhash.glsl``."""
    path = Path(__file__).resolve().parents[2] / "glsl"
    if not (path / "bh_lookup.glsl").is_file():
        try:
            path = Path(str(resources.files("blockhash.glsl")))
        except ModuleNotFoundError:
            pass
    if not (path / "bh_lookup.glsl").is_file():
        raise GLUnavailableError(
            f"the GLSL library was not found at {path} (bh_lookup.glsl missing); reinstall "
            "blockhash (pip install .) so that its glsl/ directory ships with it")
    return path


@dataclass(frozen=True)
class Source:
    """A preprocessed shader: the text and the file of each ``#line`` source number."""

    text: str
    files: tuple[str, ...]

    def locate(self, message: str) -> str:
        """Rewrite compiler locations ``S:N(col)`` / ``S(N)`` into ``file:N``."""
        def repl(m):
            s, line = (int(m.group(1)), int(m.group(2))) if m.group(1) else (int(m.group(3)), int(m.group(4)))
            if line >= LINE_STRIDE:
                s, line = divmod(line, LINE_STRIDE)
            name = self.files[s] if 0 <= s < len(self.files) else f"source {s}"
            return f"{name}:{line}"
        return re.sub(r"\b(\d+):(\d+)\(\d+\)|\b(\d+)\((\d+)\)", repl, message)


def preprocess(name: str, prologue: str = "", *, root: Path | None = None) -> Source:
    """Splice the includes of ``name`` after ``#version`` and ``prologue``.

    Raises InputError for a missing file or an include cycle (naming the chain).
    """
    root = root or glsl_dir()
    files: list[str] = ["<defines>"]
    out = [GLSL_VERSION, prologue.rstrip("\n")] if prologue else [GLSL_VERSION]

    def splice(fname: str, stack: tuple[str, ...], parent: str, parent_line: int) -> None:
        if fname in stack:
            chain = " -> ".join((*stack, fname))
            raise InputError(f"include cycle in the GLSL library: {chain}; remove one of these includes")
        path = root / fname
        if not path.is_file():
            where = f" (included from {parent}:{parent_line})" if parent else ""
            raise InputError(f"GLSL file {fname!r} not found in {root}{where}")
        sid = len(files)
        files.append(fname)
        out.append(f"#line {sid * LINE_STRIDE + 1} {sid}")
        for lineno, line in enumerate(path.read_text().splitlines(), start=1):
            m = _INCLUDE.match(line)
            if m:
                splice(m.group(1), (*stack, fname), fname, lineno)
                out.append(f"#line {sid * LINE_STRIDE + lineno + 1} {sid}")
            else:
                out.append(line)

    splice(name, (), "", 0)
    return Source(text="\n".join(out) + "\n", files=tuple(files))


# --- variants -----------------------------------------------------------------------------

#: Choice -> (GLSL selector define, {name: id}); ids match glsl/bh_variants.glsl.
CHOICES = {
    "search": ("BH_THRESHOLD_SEARCH", {"linear": 0, "binary": 1}),
    "dedup": ("BH_DEDUP", {"branch": 0, "zero": 1, "set": 2}),
    "priority": ("BH_PRIORITY", {"off": 0, "on": 1}),
    "select": ("BH_SELECT", {"insertion": 0, "network": 1, "packed": 2, "merge": 3}),
    "cull": ("BH_CULL", {"off": 0, "box": 1}),
}


@dataclass(frozen=True)
class Variant:
    """One shader variant: a named choice per algorithm stage.

    search : {'linear', 'binary'}     threshold search (section 7)
    dedup : {'branch', 'zero', 'set'} duplicate blocks skipped, or "multiplied by zero" (both
                                      scan a local array of taken blocks), or skipped with
                                      the taken blocks in registers (no indexed array)
    priority : {'on', 'off'}          buckets by priority alpha (4.4), or table order
    select : {'insertion', 'network', 'packed', 'merge'} k-nearest selection (packed:
                                      unrolled network on uint keys, exact up to near-ties
                                      that the CPU reference reproduces with slot_bits;
                                      merge: the same keys, a block at a time, by a
                                      bitonic merge)
    cull : {'off', 'box'}             blocks farther than the current k-th neighbour (by
                                      the box in their spare words) skipped, not fetched;
                                      same results.  The default preset's walk
                                      (BH_BEST_FIRST) culls whatever this field, and
                                      its culled blocks are not examined (they do not
                                      count toward A * k: blockhash/index/lookups/walk.py)

    A name lists the choices in this order, '-'-separated; a name of the first four
    (the paper's stages) means cull 'off'.
    """

    search: str = "binary"
    dedup: str = "set"
    priority: str = "on"
    select: str = "packed"
    cull: str = "box"

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            valid = CHOICES[f.name][1]
            if value not in valid:
                raise InputError(f"variant {f.name}={value!r} is not known; choose one of "
                                 f"{', '.join(valid)}")

    @property
    def packed_keys(self) -> bool:
        """Whether the selection keeps packed uint keys (the CPU reference's ``slot_bits`` mode)."""
        return self.select in ("packed", "merge")

    @property
    def name(self) -> str:
        return "-".join(getattr(self, f.name) for f in fields(self))

    @classmethod
    def parse(cls, name: str) -> "Variant":
        """'default', 'paper', or 'search-dedup-priority-select[-cull]' such as
        'linear-zero-on-insertion' (cull off) or 'binary-set-on-packed-box'."""
        if name in NAMED:
            return NAMED[name]
        parts = name.split("-")
        if len(parts) == len(CHOICES) - 1:
            parts.append("off")
        if len(parts) != len(CHOICES):
            raise InputError(f"shader variant {name!r} is not known; the variants are: "
                             + ", ".join(variants()))
        try:
            return cls(*parts)
        except InputError as exc:
            raise InputError(f"shader variant {name!r} is not known ({exc}); the variants are: "
                             + ", ".join(variants())) from None

    def defines(self) -> dict[str, int]:
        return {CHOICES[f.name][0]: CHOICES[f.name][1][getattr(self, f.name)] for f in fields(self)}

    def __repr__(self) -> str:
        return f"Variant({self.name!r})"


#: Named variants: 'default' is the fastest measured here, 'paper' follows section 7 literally.
NAMED = {
    "default": Variant(),
    "paper": Variant(search="linear", dedup="zero", priority="on", select="insertion", cull="off"),
}


#: The stages whose choice the default preset's index does not see, and why: its lookup is
#: the nearest-box-first walk over the adaptive trees (blockhash/index/lookups/walk.py).
IGNORED_BY_DEFAULT_INDEX = {
    "search": "the adaptive layout descends its trees; only grid layouts search thresholds",
    "priority": "the walk visits buckets nearest box first, never by priority",
    "cull": "the walk culls by box whatever this choice",
}


def variants(*, for_default_index: bool = False) -> list[str]:
    """Every variant name: the named ones, then each combination of choices.

    ``for_default_index=True`` gives only the combinations that differ on the default
    preset's index: the stages of :data:`IGNORED_BY_DEFAULT_INDEX` held at the default
    variant's choice (the others give the same shader results there).
    """
    stages = {name: list(v[1]) for name, v in CHOICES.items()}
    if for_default_index:
        base = NAMED["default"]
        stages.update({name: [getattr(base, name)] for name in IGNORED_BY_DEFAULT_INDEX})
    combos = ["-".join(c) for c in itertools.product(*stages.values())]
    return [*NAMED, *combos]


def define_block(defines: dict[str, object]) -> str:
    """``#define NAME value`` lines, every value written out (falsy ones too)."""
    lines = []
    for key, value in defines.items():
        if isinstance(value, bool):
            value = int(value)
        lines.append(f"#define {key} {value}")
    return "\n".join(lines)


#: Programs per (context, fragment file, source text): llvmpipe takes seconds per compile.
_PROGRAMS: dict = {}


@dataclass(frozen=True)
class Compiled:
    """One fragment shader as :func:`compile_program` handed it to the GL driver."""

    file: str
    defines: dict
    text: str


_RECORDS: list[list[Compiled]] = []


@contextmanager
def recording():
    """Collect every fragment shader compiled inside the block, cached programs included,
    as a list of :class:`Compiled` (the GPU compiler check reads what the renderer and the
    lookup really run this way, whichever code path chose the defines)."""
    got: list[Compiled] = []
    _RECORDS.append(got)
    try:
        yield got
    finally:
        _RECORDS.remove(got)


def compile_program(ctx, fragment: str, defines: dict[str, object], *, vertex: str = None):
    """Compile ``fragment`` (a file of the library) with ``defines`` into a moderngl Program.

    Programs are cached per context and source; callers must not release them.  A
    failed compile raises ShaderCompileError naming file:line, the variant (when the
    defines select one) and the active defines.
    """
    import moderngl

    src = preprocess(fragment, define_block(defines) + "\n" + strict.prologue())
    for record in _RECORDS:
        record.append(Compiled(fragment, dict(defines), src.text))
    key = (id(ctx), fragment, src.text, vertex)
    if key in _PROGRAMS:
        return _PROGRAMS[key]
    try:
        program = ctx.program(vertex_shader=vertex or FULLSCREEN_VS, fragment_shader=src.text)
    except moderngl.Error as exc:
        active = ", ".join(f"{k}={v}" for k, v in defines.items())
        raise ShaderCompileError(f"{fragment} failed to compile{_variant_of(defines)}: "
                                 f"{src.locate(str(exc)).strip()}\nactive defines: {active}") from None
    _PROGRAMS[key] = program
    return program


def _variant_of(defines: dict) -> str:
    """' (variant NAME)' when ``defines`` hold every variant selector, else ''."""
    names = []
    for selector, options in CHOICES.values():
        if selector not in defines:
            return ""
        names.append(next((n for n, i in options.items() if i == defines[selector]), "?"))
    return f" (variant {'-'.join(names)})"


#: A triangle covering the viewport; no vertex attributes.
FULLSCREEN_VS = """#version 450 core
void main() {
    vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
    gl_Position = vec4(p, 0.0, 1.0);
}
"""
