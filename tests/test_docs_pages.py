"""The README is a front page and the pages under docs/ hold the detail; both stay navigable.

The README is at most 300 lines; every relative link in it and in docs/*.md names a file
that exists (and a heading of it, for a ``#anchor``); no heading cites an issue number;
every ``python -m lab ...`` command in their code blocks is accepted by the command line's
parser (flags are a public contract: an example must not name a flag that is gone); and every
``lab.module.name`` and repository path they quote in code spans exists.
"""

import importlib
import re
import shlex
from pathlib import Path

import pytest

from lab.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
ISSUE = re.compile(r"\bissues?\s*#?\d+", re.I)
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", re.M | re.S)


def page_id(path):
    return str(path.relative_to(ROOT))


def prose(text):
    """The text without fenced code blocks and inline code (links there are not links)."""
    return re.sub(r"`[^`\n]*`", "", FENCE.sub("", text))


def headings(text):
    return [line.lstrip("#").strip() for line in FENCE.sub("", text).splitlines() if re.match(r"#{1,6} ", line)]


def anchor(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.replace("`", "").strip().lower()).replace(" ", "-")


def test_readme_is_a_front_page():
    n_lines = len((ROOT / "README.md").read_text().splitlines())
    assert n_lines <= 300, f"README.md has {n_lines} lines; move detail to a page under docs/"


def test_docs_index_lists_every_page():
    index = (ROOT / "docs" / "index.md").read_text()
    missing = [p.name for p in PAGES[1:] if p.name != "index.md" and f"({p.name})" not in index]
    assert not missing, f"docs/index.md does not link {missing}"


@pytest.mark.parametrize("page", PAGES, ids=page_id)
def test_relative_links_resolve(page):
    problems = []
    for target in LINK.findall(prose(page.read_text())):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto: ...
            continue
        file_part, _, fragment = target.partition("#")
        dest = (page.parent / file_part).resolve() if file_part else page
        if not dest.exists():
            problems.append(f"{target}: no such file")
        elif fragment and dest.suffix == ".md" and fragment not in {anchor(h) for h in headings(dest.read_text())}:
            problems.append(f"{target}: no heading with anchor #{fragment} in {page_id(dest)}")
    assert not problems, f"{page_id(page)}: " + "; ".join(problems)


@pytest.mark.parametrize("page", PAGES, ids=page_id)
def test_no_heading_cites_an_issue(page):
    cited = [h for h in headings(page.read_text()) if ISSUE.search(h)]
    assert not cited, f"{page_id(page)}: headings cite an issue number: {cited}"


def test_readme_cites_no_issue():
    lines = [line for line in (ROOT / "README.md").read_text().splitlines() if ISSUE.search(line)]
    assert not lines, f"README.md cites issue numbers: {lines}"


def commands(text):
    """Every ``python -m lab COMMAND ...`` line of the fenced code blocks, continuations joined."""
    for block in FENCE.findall(text):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.removeprefix("$ ").split("  #", 1)[0].strip()
            if line.startswith("python -m lab ") and "..." not in line:
                yield line


@pytest.mark.parametrize("page", PAGES, ids=page_id)
def test_command_examples_parse(page):
    parser = build_parser()
    problems = []
    for line in commands(page.read_text()):
        # placeholders in the examples: a count N
        argv = ["100" if word == "N" else word for word in shlex.split(line)[3:]]
        try:
            parser.parse_args(argv)
        except SystemExit:
            problems.append(line)
    assert not problems, f"{page_id(page)}: the parser refuses " + "; ".join(problems)


def resolves(dotted):
    """Whether ``lab.a.b.c`` is an importable module, or a module and attributes of it."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


@pytest.mark.parametrize("page", PAGES, ids=page_id)
def test_quoted_names_and_paths_exist(page):
    missing = set()
    for code in re.findall(r"`([^`\n]+)`", FENCE.sub("", page.read_text())):
        missing |= {name for name in re.findall(r"\blab(?:\.[A-Za-z_]\w*)+", code) if not resolves(name)}
        for word in code.split():
            m = re.match(r"(?:lab|data|figures|benchmarks|scripts|notebooks|tests|examples|docs)/[\w./-]*", word)
            if m and not any(c in word for c in "*{}") and "NN" not in word and not (ROOT / m.group(0)).exists():
                missing.add(m.group(0))
    assert not missing, f"{page_id(page)} quotes what does not exist: {sorted(missing)}"
