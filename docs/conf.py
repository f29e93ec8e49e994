"""Sphinx configuration of blockhash's documentation site.

Build: ``python -m sphinx -W --keep-going -b html docs docs/_build/html`` (warnings are
errors; ``.ci/run`` and ``tests/test_docs_site.py`` build it so).  The pages are Markdown
(MyST); the API reference is autodoc reading the numpy-style docstrings (numpydoc).
"""

from pathlib import Path

import blockhash

ROOT = Path(__file__).resolve().parents[1]

project = "blockhash"
author = "the blockhash authors"
copyright = "blockhash authors"
release = version = blockhash.__version__

extensions = ["myst_parser", "sphinx.ext.autodoc", "numpydoc"]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "**/.pytest_cache"]

# Markdown: ``{include}``, ``:::`` fences and definition lists; headings get anchors so that
# pages link to each other's sections as on GitHub.
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# numpydoc: no autosummary tables of every member (the reference lists what __all__ names);
# parameters are read from the docstrings as written.
numpydoc_show_class_members = False
numpydoc_validation_checks = set()
autodoc_member_order = "bysource"
autodoc_typehints = "none"

html_theme = "furo"
html_title = f"blockhash {release}"


# --------------------------------------------------------------------------- docstrings
# Some docstrings list their fields in columns, ``name : type    what it is`` (the
# dataclasses' options: RenderPlan, EstimateOptions, ...); numpydoc reads a field's text on
# the lines below it.  This moves each such text there, under a "Parameters" heading where the
# docstring has no section, before numpydoc reads the docstring.

import re  # noqa: E402

FIELD = re.compile(r"^(?P<name>[A-Za-z_*][\w, *]*) : (?P<type>.+?)(?:\s{2,}(?P<text>\S.*))?$")
SECTION_RULE = re.compile(r"^\s*-{3,}\s*$")


def columns_to_numpydoc(lines: list[str]) -> list[str]:
    """``lines`` with column-style fields written as numpydoc fields (see above)."""
    columns = any((m := FIELD.match(line)) and m["text"] for line in lines)
    if not columns:
        return lines
    out, section, i = [], False, 0
    while i < len(lines):
        line = lines[i]
        if i + 1 < len(lines) and line.strip() and SECTION_RULE.match(lines[i + 1]):
            section = True
            out += [line, lines[i + 1]]
            i += 2
            continue
        m = FIELD.match(line)
        if not m:
            out.append(line)
            i += 1
            continue
        if not section:
            if out and out[-1].strip():
                out.append("")
            out += ["Parameters", "----------"]
            section = True
        out.append(f"{m['name']} : {m['type'].rstrip()}")
        if m["text"]:
            out.append("    " + m["text"])
        i += 1
        while i < len(lines) and lines[i].startswith("  ") and lines[i].strip():
            out.append("    " + lines[i].strip())
            i += 1
    return out


def _process_docstring(app, what, name, obj, options, lines):
    lines[:] = columns_to_numpydoc(lines)


# --------------------------------------------------------------------------- repository files
# The pages link to the repository's other Markdown files as GitHub shows them
# (``../BENCHMARKS.md#the-render-in-passes``); on the site such a link goes to the page that
# includes the file (``benchmarks-record.md``), at the same heading.

#: Markdown files outside docs/ -> the page of the site that includes each.
INCLUDED = {ROOT / "BENCHMARKS.md": "benchmarks-record"}


def _retarget(app, doctree):
    from sphinx import addnodes

    for node in doctree.findall(addnodes.pending_xref):
        if node.get("reftype") != "myst" or node.get("refdomain") != "doc":
            continue
        target = node["reftarget"]
        if target in app.env.found_docs:
            continue
        page = INCLUDED.get((Path(app.srcdir) / (target + ".md")).resolve())
        if page is not None:
            node["reftarget"] = page


def setup(app):
    # before numpydoc (priority 500) reads the docstring
    app.connect("autodoc-process-docstring", _process_docstring, priority=100)
    app.connect("doctree-read", _retarget)
