"""The package reads as its data flows: index -> gl -> render -> command line.

Every import between blockhash's modules (lazy ones inside functions included)
goes from a later part to an earlier one, never back; modules stay short unless
their docstring says why not.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "blockhash"
#: Rank of each part in the data flow; a module may import only ranks <= its own.
RANKS = {"errors": 0, "validate": 0, "index": 1, "gl": 2, "render": 3,
         "bench": 4, "tradeoff": 4, "testing": 4, "cli": 5, "cli_estimate": 5, "cli_images": 5, "__init__": 5, "__main__": 5}
#: Lines above which a module's docstring must say why it is long.
LONG_MODULE = 420
LONG_REASON = "Why this module is long:"


def _modules():
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _dotted(path: Path) -> list[str]:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return parts[:-1] if parts[-1] == "__init__" else parts


def _rank(dotted: list[str]) -> int:
    """blockhash.X... -> the rank of part X (the package root counts as the top)."""
    if len(dotted) == 1:
        return RANKS["__init__"]
    part = dotted[1]
    if part not in RANKS:
        raise AssertionError(f"blockhash.{part} belongs to no part; add it to RANKS in {__file__}")
    return RANKS[part]


def _imports(path: Path):
    """(line, imported dotted module) for every blockhash import in ``path``."""
    here = _dotted(path)
    package = here if path.name == "__init__.py" else here[:-1]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "blockhash":
                    yield node.lineno, alias.name.split(".")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)]
                target = base + (node.module.split(".") if node.module else [])
            elif node.module and node.module.split(".")[0] == "blockhash":
                target = node.module.split(".")
            else:
                continue
            if len(target) == 1:  # "from blockhash import x": x may be a module
                for alias in node.names:
                    yield node.lineno, target + [alias.name]
            else:
                yield node.lineno, target


@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_module_imports_only_earlier_parts(path):
    own = _rank(_dotted(path))
    backward = [f"line {line}: blockhash.{'.'.join(t[1:])}" for line, t in _imports(path)
                if len(t) > 1 and t[1] in RANKS and _rank(t) > own]
    assert not backward, f"{path.name} imports against the data flow: {backward}"


def test_the_three_parts_are_packages():
    for part in ("index", "gl", "render"):
        assert (PACKAGE / part / "__init__.py").is_file()
    assert not sorted(p.name for p in PACKAGE.glob("*.py")
                      if p.stem not in RANKS), "top-level modules outside the known parts"


@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_long_modules_say_why(path):
    lines = path.read_text().count("\n")
    if lines > LONG_MODULE:
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        assert LONG_REASON in doc, (f"{path.name} has {lines} lines; split it, or say in its "
                                    f"docstring '{LONG_REASON} ...'")


def test_import_check_sees_a_backward_import(tmp_path):
    """The checker itself can fail: an index module importing the renderer is caught."""
    fake = PACKAGE / "index" / "_probe_backward.py"
    try:
        fake.write_text("from ..render import pipeline\n")
        with pytest.raises(AssertionError, match="against the data flow"):
            test_module_imports_only_earlier_parts(fake)
    finally:
        fake.unlink()
