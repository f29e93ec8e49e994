"""The docs quote what the project measured: the figures of README.md and of the docs' pages
match the JSON the tools wrote and BENCHMARKS.md, and no doc or source points outside the
repository."""

import json
import re
from pathlib import Path

import pytest
from project_tree import project_files

ROOT = Path(__file__).resolve().parents[1]


def rows(name):
    return json.loads((ROOT / "docs" / name).read_text())["rows"]


def quoted(pattern, page="README.md"):
    """The numbers ``page`` (README.md or a page of the docs) gives where ``pattern`` (a regex
    with groups) matches."""
    m = re.search(pattern, re.sub(r"\s+", " ", (ROOT / page).read_text()))
    assert m, f"{page} no longer says {pattern!r}; update this test with the text"
    return [float(g) for g in m.groups()]


def pct(x):
    return round(100 * x, 2)


def test_the_default_walks_worst_map_figures_match_the_accuracy_knob_json():
    a8, a64 = quoted(r"every evaluation map misses at most ([\d.]+)% at A = 8 and ([\d.]+)% at A = 64",
                     "docs/rendering.md")
    default = [r for r in rows("accuracy-knob.json") if r["preset"] == "default" and not r["config"]]
    assert pct(max(r["fn_mean"] for r in default if r["A"] == 8)) == a8
    assert pct(max(r["fn_mean"] for r in default if r["A"] == 64)) == a64


def test_the_far_query_figures_match_the_accuracy_knob_json():
    a8, a64 = quoted(r"the walk misses ([\d.]+)% of them at A = 8 and ([\d.]+)% at A = 64",
                     "docs/rendering.md")
    default = [r for r in rows("accuracy-knob.json") if r["preset"] == "default" and not r["config"]]
    far8 = max(r["fn_far"] for r in default if r["A"] == 8)
    far64 = max(r["fn_far"] for r in default if r["A"] == 64)
    assert round(100 * far8, 1) == a8 and round(100 * far64, 2) == a64


TEXT = ("*.md", "*.py", "*.toml", "*.sh", "*.glsl", "*.frag")


OUTSIDE = [r"\.\./shared", r"\bDESIGN\.md\b", r"/work/", r"(?i)\bin this (task|session)\b",
           r"\(issue \d+"]


def outside_hits(pattern, files):
    """``file:line`` of each line of ``files`` that matches ``pattern``."""
    return [f"{p.relative_to(ROOT)}:{i + 1}" for p in files
            for i, line in enumerate(p.read_text(errors="replace").splitlines())
            if re.search(pattern, line)]


@pytest.mark.parametrize("pattern", OUTSIDE)
def test_nothing_points_outside_the_repository(pattern):
    """The project's own text files (git's tracked files: not a virtual environment, build
    output or anything else a user keeps in the checkout) name nothing outside it."""
    here = Path(__file__).resolve()
    files = [p for p in project_files(*TEXT) if p.resolve() != here]
    hits = outside_hits(pattern, files)
    assert not hits, f"references outside the repository ({pattern}): {hits[:10]}"


def test_the_speed_figures_match_the_bench_json():
    walk, kd, ckd, cells, hashed = quoted(
        r"the default lookup \(the walk\) takes ([\d.]+) s, against ([\d.]+) s for the exact "
        r"kd-tree shader and ([\d.]+) s for cKDTree on two cores; the Hilbert cells lookup "
        r"takes ([\d.]+) s and the hash without the walk ([\d.]+) s", "docs/benchmarks.md")
    bench = {r["method"]: r["wall_median"]
             for r in json.loads((ROOT / "docs" / "bench-cells.json").read_text())}
    assert round(bench["BH default"], 2) == walk
    assert round(bench["kd-tree shader (exact)"], 2) == kd
    assert round(bench["cKDTree (CPU, all workers)"], 2) == ckd
    assert round(bench["BH default (Hilbert cells)"], 2) == cells
    assert round(bench["BH default (tables hashed, walk off)"], 2) == hashed


BENCHMARKS = (ROOT / "BENCHMARKS.md").read_text()

#: A figure a page quotes from BENCHMARKS.md: a number or a range, then x, %, s or ms.
FIGURE = re.compile(r"(?<![\w.])(\d+(?:\.\d+)?)(?:-(\d+(?:\.\d+)?))?(?:x|%| ms\b| s\b)")


@pytest.mark.parametrize("page, section", [("README.md", "## Against Mitsuba 3"),
                                           ("docs/benchmarks.md", None),
                                           ("docs/workers.md", "## How fast")])
def test_the_figures_the_pages_quote_are_benchmarks_figures(page, section):
    """README's table against Mitsuba 3 and the docs' summaries copy their figures from
    BENCHMARKS.md: each number (each end of a range) is one of its numbers."""
    text = (ROOT / page).read_text()
    if section:
        assert section in text, f"{page} has no section {section!r}"
        text = text.split(section, 1)[1].split("\n## ", 1)[0]
    numbers = {n for m in FIGURE.finditer(text) for n in m.groups() if n}
    assert numbers, f"{page} quotes no figure"
    missing = sorted(n for n in numbers if not re.search(rf"(?<![\d.]){re.escape(n)}(?!\d)", BENCHMARKS))
    assert not missing, f"{page} quotes figures that BENCHMARKS.md does not hold: {missing}"


def claim_rows():
    """(claim, section, command, date) of BENCHMARKS.md's current-state table."""
    table = BENCHMARKS.split("## Current state, claim by claim", 1)[1].split("\n## ", 1)[0]
    rows = [line.strip("|").split(" | ") for line in table.splitlines()
            if line.startswith("| ") and not line.startswith(("| claim ", "| ---"))]
    assert len(rows) >= 10, "BENCHMARKS.md's current-state table has gone"
    return [[cell.strip() for cell in row] for row in rows]


def test_each_benchmark_claim_has_its_section_a_command_that_exists_and_a_date():
    from blockhash.cli import build_parser

    headings = re.findall(r"^## (.+)$", BENCHMARKS, flags=re.M)
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    for claim, section, command, date in claim_rows():
        assert any(h.startswith(section) for h in headings), f"no section {section!r} for {claim!r}"
        assert re.fullmatch(r"\d{4}-\d\d-\d\d|-", date), (claim, date)
        for tool in re.findall(r"tools/[\w/]+\.(?:py|sh)", command):
            assert (ROOT / tool).is_file(), f"{claim!r}: {tool} does not exist"
        for sub_name in re.findall(r"`(?:/usr/bin/time -v )?blockhash (\w+)", command):
            assert sub_name in sub.choices, f"{claim!r}: no command blockhash {sub_name}"
        for out in re.findall(r"--json (docs/[\w./-]+)", command):
            assert (ROOT / out).is_file(), f"{claim!r}: {out} is not in the repository"


@pytest.mark.parametrize("phrase", ["previous default", "the default before", "before this change",
                                    "a later run", "an earlier run", "was the default", "no longer"])
def test_benchmarks_reads_as_the_current_state_outside_its_history(phrase):
    body = BENCHMARKS.split("\n## History", 1)[0]
    assert phrase not in body.lower(), f"BENCHMARKS.md says {phrase!r} outside its History section"


#: A path a source file cites: a folder of the repository, then a module or a shader (the
#: wheel's ``blockhash/glsl/`` is the installed name of ``glsl/``).
CITED = re.compile(r"(?<![\w./-])((?:blockhash/(?!glsl/)|glsl/|tools/|tests/)[\w/.-]*\w\.(?:py|glsl|frag))")


def test_every_path_a_source_file_cites_exists():
    """Comments and docstrings of .py and .glsl files, and the Markdown docs, point at files
    that are there (a moved module leaves no citation of its old path behind)."""
    missing = []
    for path in project_files("*.py", "*.glsl", "*.frag", "*.md"):
        rel = path.relative_to(ROOT).as_posix()
        if not rel.startswith(("blockhash/", "glsl/", "tools/", "tests/", "docs/")) and \
                rel not in ("README.md", "BENCHMARKS.md"):
            continue
        for n, line in enumerate(path.read_text().splitlines(), 1):
            for cited in CITED.findall(line):
                if not (ROOT / cited).exists():
                    missing.append(f"{rel}:{n}: {cited}")
    assert not missing, "cited paths that do not exist:\n" + "\n".join(missing)
