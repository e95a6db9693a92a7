"""Sphinx configuration of the documentation site (scripts/docs builds it into build/docs/).

The source directory is the repository root, this folder only holds the configuration, so
every page keeps the relative links it has on GitHub: the front page is README.md itself,
the topic pages are docs/*.md and docs/design/*.md, the chapters are the recorded runs
figures/notebooks/NN_*.ipynb (written by scripts/reproduce; never executed here), and the
API reference is docs/api/*.rst (generated from ``__all__`` by docs/_ext/lab_api.py). The
sidebar's table of contents is added to the README when Sphinx reads it (GitHub never sees
it). Formulas are typeset by MathJax copied into the site (docs/_ext/lab_mathjax.py), so
they render offline; a page's later top-level headings go under its title
(docs/_ext/lab_sections.py). The site's own styles are docs/_static/site.css: what is
wider than the content column scrolls. Why Sphinx, MyST-NB and Furo: docs/site.md.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path[:0] = [str(DOCS / "_ext"), str(ROOT)]

import lab_mathjax  # noqa: E402  (docs/_ext, just put on the path)

project = "lab"
author = "the lab authors"
copyright = "the lab authors, MIT licence"
extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.napoleon", "lab_api", "lab_fuzzy_index", "lab_mathjax", "lab_sections"]

root_doc = "README"
include_patterns = ["README.md", "docs/*.md", "docs/design/*.md", "docs/api/*.rst", "figures/notebooks/*.ipynb"]
# folders Sphinx need not walk at all (include_patterns alone still walks them)
exclude_patterns = [
    ".*",
    "build",
    "data",
    "lab",
    "tests",
    "benchmarks",
    "notebooks",
    "scripts",
    "examples",
    "shared",
    "*.egg-info",
    "docs/_ext",
    "docs/_static",
    "docs/_templates",
]
templates_path = ["_templates"]

# --- Markdown and notebooks (MyST-NB): recorded outputs only, nothing is executed ---
nb_execution_mode = "off"
nb_merge_streams = True
nb_render_markdown_format = "myst"
myst_heading_anchors = 4  # GitHub's anchors (README.md#for-students)
myst_enable_extensions = ["dollarmath"]
# "$$...$$" inside a paragraph is display math, as JupyterLab shows it (chapter 01's goals)
myst_dmath_double_inline = True

# --- math: MathJax 3 from the site itself (docs/_ext/lab_mathjax.py copies it), never a CDN ---
mathjax_path = lab_mathjax.MATHJAX_PATH
# (MyST adds the classes MathJax processes: its math and the notebooks' outputs)
mathjax3_config = {"options": {}}

# --- API reference ---
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_typehints_format = "short"
autodoc_preserve_defaults = True
napoleon_google_docstring = False
napoleon_numpy_docstring = True
# The docstrings write "name : what it is, with units" (prose, not a type): no type links.
napoleon_use_param = False
napoleon_use_rtype = False

# --- cross-references: every one must resolve (-n); what may not, and why ---
nitpicky = True
# Types of other packages (numpy, torch, scipy, the standard library, ...) have no target:
# the build is offline, so it reads no intersphinx inventory. Private names (a leading
# underscore, e.g. an internal return type in an annotation) are no part of the API and get
# no entry. Every other lab.* name must resolve.
nitpick_ignore_regex = [
    (r"py:(class|obj|data|exc|func|meth|attr|mod)", r"(?!lab\b)[\w.]+"),
    (r"py:(class|obj|func|meth|attr)", r"lab\.[\w.]*\._\w+"),
]

# --- HTML ---
html_theme = "furo"
html_title = "lab: soft robot control with a learned differentiable model"
html_copy_source = False
html_show_sourcelink = False
html_last_updated_fmt = None
html_additional_pages = {"index": "redirect.html"}  # index.html -> README.html, the front page
# wide formulas and long code lines scroll inside the 46em column, instead of being cut off
html_static_path = ["_static"]
html_css_files = ["site.css"]


def _linked(index: Path) -> list[str]:
    """The pages ``index`` links, in its order, as document names from the root."""
    names = []
    for target in re.findall(r"\]\(([\w./-]+)\.md(?:#[\w-]*)?\)", index.read_text()):
        path = (index.parent / f"{target}.md").resolve()
        if path.is_relative_to(ROOT / "docs") and path.exists():
            names.append(_name(path))
    return list(dict.fromkeys(names))


def _name(path: Path) -> str:
    """The document name of a source file: its path from the root, without suffix."""
    return path.relative_to(ROOT).with_suffix("").as_posix()


def _toctree(caption: str, entries: list[str]) -> str:
    return "\n```{toctree}\n:hidden:\n:caption: " + caption + "\n\n" + "\n".join(entries) + "\n```\n"


def _site_contents() -> str:
    """The sidebar: chapters, topic pages and design notes (each index's order first), API."""
    chapters = [_name(p) for p in sorted((ROOT / "figures" / "notebooks").glob("[0-9][0-9]_*.ipynb"))]
    topics = ["docs/index", *_linked(ROOT / "docs" / "index.md")]
    topics = [t for t in topics if not t.startswith("docs/design/")]
    topics += sorted({_name(p) for p in (ROOT / "docs").glob("*.md")} - set(topics))
    design = ["docs/design/index", *_linked(ROOT / "docs" / "design" / "index.md")]
    design += sorted({_name(p) for p in (ROOT / "docs" / "design").glob("*.md")} - set(design))
    return (
        _toctree("The course (recorded runs)", chapters)
        + _toctree("Topics and results", list(dict.fromkeys(topics)))
        + _toctree("Design notes", list(dict.fromkeys(design)))
        + _toctree("API reference", ["docs/api/index"])
    )


def _add_contents(app, docname, source):
    if docname == app.config.root_doc:
        source[0] += _site_contents()


def setup(app):
    app.connect("source-read", _add_contents)
