"""The package reads as its data flows: scene -> photons (and their device kernels) -> index ->
gl -> frame -> passes ->
reference -> evaluate -> studies -> command line.

Every import between blockhash's modules (lazy ones inside functions included)
goes from a later part to an earlier one, never back; modules stay short unless
their docstring says why not.
"""

import ast
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "blockhash"
#: Rank of each part in the data flow; a module may import only ranks <= its own.
RANKS = {"errors": 0, "validate": 0, "code_version": 0, "scene": 1, "photons": 2, "device": 2, "index": 3, "gl": 4,
         "frame": 5, "passes": 6, "reference": 7, "evaluate": 8, "studies": 9, "cli": 10,
         "__init__": 10, "__main__": 10}
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
            # "from blockhash.pkg import x": x may be a module; callers that want the
            # module strip the names that are not (_module_graph).
            for alias in node.names:
                yield node.lineno, target + [alias.name]


@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_module_imports_only_earlier_parts(path):
    own = _rank(_dotted(path))
    backward = [f"line {line}: blockhash.{'.'.join(t[1:])}" for line, t in _imports(path)
                if len(t) > 1 and t[1] in RANKS and _rank(t) > own]
    assert not backward, f"{path.name} imports against the data flow: {backward}"


def test_the_three_parts_are_packages():
    for part in ("scene", "photons", "index", "gl", "frame", "passes", "reference", "evaluate", "studies", "cli"):
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


@pytest.fixture
def tree_copy(tmp_path, monkeypatch):
    """A copy of blockhash/ and tools/ that the checks read instead of the checkout, so that a
    probe module written into it reaches no other test (the suite runs in parallel processes:
    another would import it, list it or hash it into the source digest)."""
    ignore = shutil.ignore_patterns("__pycache__")
    shutil.copytree(PACKAGE, tmp_path / "blockhash", ignore=ignore)
    shutil.copytree(ROOT / "tools", tmp_path / "tools", ignore=ignore)
    monkeypatch.setitem(globals(), "ROOT", tmp_path)
    monkeypatch.setitem(globals(), "PACKAGE", tmp_path / "blockhash")
    return tmp_path


def test_import_check_sees_a_backward_import(tree_copy):
    """The checker itself can fail: an index module importing the renderer is caught."""
    fake = PACKAGE / "index" / "_probe_backward.py"
    try:
        fake.write_text("from ..frame import pipeline\n")
        with pytest.raises(AssertionError, match="against the data flow"):
            test_module_imports_only_earlier_parts(fake)
    finally:
        fake.unlink()


def _module_graph():
    """{dotted module: {dotted blockhash modules it imports}}, lazy imports included."""
    modules = {".".join(_dotted(p)): p for p in _modules()}
    graph = {}
    for name, path in modules.items():
        targets = set()
        for _, t in _imports(path):
            dotted = ".".join(t)
            while dotted and dotted not in modules:  # "from pkg.mod import name": the module
                dotted = dotted.rpartition(".")[0]
            if dotted and dotted != name and dotted != "blockhash":
                targets.add(dotted)
        graph[name] = targets
    return graph


def test_no_import_circles():
    """No module reaches itself through imports, lazy ones inside functions included."""
    graph = _module_graph()
    circles = []
    for start in graph:
        stack, seen = [(start, [start])], set()
        while stack:
            node, path = stack.pop()
            for nxt in graph.get(node, ()):
                if nxt == start:
                    circles.append(" -> ".join(path + [start]))
                elif nxt not in seen:
                    seen.add(nxt)
                    stack.append((nxt, path + [nxt]))
    assert not circles, f"import circles: {sorted(set(circles))[:5]}"


@pytest.mark.slow
@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_private_names_cross_modules(path):
    """``from blockhash.x import _name`` is not allowed: what another module uses is public."""
    own = ".".join(_dotted(path))
    private = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("blockhash"):
            if node.module != own:
                private += [f"line {node.lineno}: {node.module}.{a.name}" for a in node.names
                            if a.name.startswith("_") and not a.name.startswith("__")]
    assert not private, f"{path.name} imports private names: {private}"


def test_tests_are_laid_out_by_package():
    """tests/ROOM/ holds the tests of blockhash/ROOM/; tests/ itself the CLI, packaging and
    cross-cutting checks."""
    tests = ROOT / "tests"
    rooms = {p.name for p in tests.iterdir() if p.is_dir() and p.name not in ("data", "__pycache__")}
    assert rooms, "no test rooms"
    assert rooms <= {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}, rooms
    for room in rooms:
        assert any((tests / room).rglob("test_*.py")), f"tests/{room}/ holds no tests"
    # deeper too: every folder of tests mirrors a package (tests/index/records/ ...)
    for folder in sorted(p for p in tests.rglob("*") if p.is_dir() and any(p.glob("test_*.py"))):
        rel = folder.relative_to(tests)
        assert (PACKAGE / rel / "__init__.py").is_file(), f"tests/{rel}/ mirrors no blockhash/{rel}/"


def test_the_circle_and_private_name_checks_can_fail(tree_copy):
    """Two probe modules that import each other (one lazily) make a circle, and one takes
    the other's private name: both checks see it."""
    a, b = PACKAGE / "index" / "_probe_a.py", PACKAGE / "index" / "_probe_b.py"
    try:
        a.write_text("from blockhash.index._probe_b import _hidden\n")
        b.write_text("def _hidden():\n    from blockhash.index import _probe_a\n")
        with pytest.raises(AssertionError, match="import circles: .*_probe_a -> blockhash.index._probe_b"):
            test_no_import_circles()
        with pytest.raises(AssertionError, match="imports private names"):
            test_no_private_names_cross_modules(a)
    finally:
        a.unlink(missing_ok=True)
        b.unlink(missing_ok=True)


def test_ruff_finds_no_unused_or_undefined_names_and_sorted_imports():
    """``ruff check`` with the project's rules (pyproject.toml: unused imports and variables,
    redefined and undefined names, import lists in isort's order)."""
    import subprocess
    import sys

    run = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "blockhash", "tools",
                          "tests"], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


#: What keeps a module name alive that the tree does not hold: an import hook or a module
#: planted in ``sys.modules`` under another name.
SHIM_MARKS = ("meta_path", "path_hooks", "MetaPathFinder", "PathEntryFinder", "sys.modules[")


def _shim_marks(path: Path) -> list[str]:
    text = path.read_text()
    return [f"line {text[:text.index(mark)].count(chr(10)) + 1}: {mark}" for mark in SHIM_MARKS
            if mark in text]


@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_module_keeps_other_module_names_alive(path):
    """Every module is imported by its own name: none installs an import hook or plants a
    module under another name (as a shim of old names would)."""
    marks = _shim_marks(path)
    assert not marks, (f"{path.name} hooks the import system ({marks}); import modules by the "
                       "names the tree gives them")


def test_importing_blockhash_adds_no_import_hook():
    import subprocess
    import sys

    probe = ("import sys; before = list(sys.meta_path) + list(sys.path_hooks); import blockhash, "
             "blockhash.cli; print([repr(f) for f in list(sys.meta_path) + list(sys.path_hooks) "
             "if f not in before and 'blockhash' in type(f).__module__])")
    run = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "[]", f"importing blockhash installs an import hook: {run.stdout}"


def _tree_modules() -> set[str]:
    return {".".join(_dotted(p)) for p in _modules()}


@pytest.mark.parametrize("folder", ["blockhash", "tests", "tools"])
def test_every_import_names_a_module_of_the_tree(folder):
    """``import blockhash.x.y`` and ``from blockhash.x.y import name`` name modules that exist:
    no old module name is imported anywhere."""
    modules = _tree_modules()
    missing = []
    for path in sorted((ROOT / folder).rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                names = [node.module]
            missing += [f"{path.relative_to(ROOT)} line {node.lineno}: {name}" for name in names
                        if name.split(".")[0] == "blockhash" and name not in modules]
    assert not missing, f"imports of modules the tree does not hold: {missing}"


def test_the_shim_checks_can_fail(tree_copy):
    """A module that puts a finder on sys.meta_path, and an import of an old module name, are
    both caught."""
    shim = PACKAGE / "_probe_shim.py"
    user = ROOT / "tools" / "_probe_old_name.py"
    try:
        shim.write_text("import sys\n\nsys.meta_path.insert(0, object())\n")
        with pytest.raises(AssertionError, match="hooks the import system"):
            test_no_module_keeps_other_module_names_alive(shim)
        user.write_text("from blockhash.index.query import query\n")
        with pytest.raises(AssertionError, match="blockhash.index.query"):
            test_every_import_names_a_module_of_the_tree("tools")
    finally:
        shim.unlink(missing_ok=True)
        user.unlink(missing_ok=True)


def test_the_files_the_suite_runs_first_are_its_files():
    """conftest.FIRST names test files by path: a renamed or deleted one would silently stop
    being run first."""
    tree = ast.parse((ROOT / "conftest.py").read_text())
    [first] = [ast.literal_eval(node.value) for node in tree.body if isinstance(node, ast.Assign)
               and [getattr(t, "id", None) for t in node.targets] == ["FIRST"]]
    assert first and all((ROOT / name).is_file() for name in first), first
