"""The README is a front page and the pages under docs/ hold the detail; both stay navigable.

The README is at most 300 lines; every relative link in it, in docs/*.md and in
docs/design/*.md names a file that exists (and a heading of it, for a ``#anchor``); no
heading cites an issue number; every ``python -m lab ...`` command in their code blocks is
accepted by the command line's parser (flags are a public contract: an example must not name
a flag that is gone); and every ``lab.module.name`` and repository path they quote in code
spans exists. The pages that describe the package's structure are checked against the tree:
docs/layout.md lists every module of ``lab/`` in its stage, the architecture page's layers
are ``tests/test_layers.py``'s and its table of moved names tells the truth, and
docs/safety.md's Limits table names every ``MAX_*`` limit the package declares.
"""

import ast
import importlib
import re
import shlex
from pathlib import Path

import pytest
from test_layers import LAYERS

from lab.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
DESIGN_PAGES = sorted((ROOT / "docs" / "design").glob("*.md"))
ALL_PAGES = PAGES + DESIGN_PAGES
LAYOUT = ROOT / "docs" / "layout.md"
ARCHITECTURE = ROOT / "docs" / "design" / "architecture.md"
#: The architecture page's table of old names: they are checked by their own test.
MOVED_HEADING = "What moved where"
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


def test_design_index_lists_every_design_page():
    index = (ROOT / "docs" / "design" / "index.md").read_text()
    missing = [p.name for p in DESIGN_PAGES if p.name != "index.md" and f"({p.name})" not in index]
    assert not missing, f"docs/design/index.md does not link {missing}"


@pytest.mark.parametrize("page", ALL_PAGES, ids=page_id)
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


@pytest.mark.parametrize("page", ALL_PAGES, ids=page_id)
def test_no_heading_cites_an_issue(page):
    cited = [h for h in headings(page.read_text()) if ISSUE.search(h)]
    assert not cited, f"{page_id(page)}: headings cite an issue number: {cited}"


def test_readme_cites_no_issue():
    lines = [line for line in (ROOT / "README.md").read_text().splitlines() if ISSUE.search(line)]
    assert not lines, f"README.md cites issue numbers: {lines}"


def commands(text):
    """Every ``python -m lab COMMAND ...`` (or ``scripts/lab COMMAND ...``, the same command
    on .venv) line of the fenced code blocks, continuations joined, as ``python -m lab ...``."""
    for block in FENCE.findall(text):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.removeprefix("$ ").split("  #", 1)[0].strip()
            if line.startswith("scripts/lab "):
                line = "python -m lab " + line.removeprefix("scripts/lab ")
            if line.startswith("python -m lab ") and "..." not in line:
                yield line


@pytest.mark.parametrize("page", ALL_PAGES, ids=page_id)
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


def quoted(text):
    """``(names, paths)`` the code spans of ``text`` quote (fenced blocks aside): dotted
    ``lab.x.y`` names -- not a quoted string such as a file's ``kind: "lab.track"`` -- and
    repository paths (without wildcards or placeholders)."""
    names, paths = set(), set()
    for code in re.findall(r"`([^`\n]+)`", FENCE.sub("", text)):
        names |= set(re.findall(r"(?<![\"'])\blab(?:\.[A-Za-z_]\w*)+", code))
        for word in code.split():
            m = re.match(r"(?:lab|data|figures|benchmarks|scripts|notebooks|tests|examples|docs)/[\w./-]*", word)
            if m and not any(c in word for c in "*{}") and "NN" not in word:
                paths.add(m.group(0))
    return names, paths


def section(text, heading):
    """The text under the Markdown heading ``heading``, to the next heading of its level or above."""
    m = re.search(rf"^(#+) {re.escape(heading)}\s*$", text, re.M)
    assert m, f"no heading {heading!r}"
    rest = text[m.end() :]
    end = re.search(rf"^#{{1,{len(m.group(1))}}} ", rest, re.M)
    return rest[: end.start()] if end else rest


@pytest.mark.parametrize("page", ALL_PAGES, ids=page_id)
def test_quoted_names_and_paths_exist(page):
    text = page.read_text()
    if page == ARCHITECTURE:  # its old names are gone on purpose: test_moved_names_are_gone
        text = text.replace(section(text, MOVED_HEADING), "")
    names, paths = quoted(text)
    missing = {n for n in names if not resolves(n)} | {p for p in paths if not (ROOT / p).exists()}
    assert not missing, f"{page_id(page)} quotes what does not exist: {sorted(missing)}"


def lab_modules() -> set[str]:
    """Every module file of the package, as a path from the repository root."""
    return {str(p.relative_to(ROOT)) for p in (ROOT / "lab").rglob("*.py") if "__pycache__" not in p.parts}


def layout_sections() -> dict[str, set[str]]:
    """docs/layout.md's module tables: per ``###`` section heading, the ``lab/...py`` paths listed."""
    out = {}
    for part in re.split(r"^### ", LAYOUT.read_text(), flags=re.M)[1:]:
        heading, _, body = part.partition("\n")
        out[heading] = set(re.findall(r"^\| `(lab/[\w/]+\.py)` \|", body, re.M))
    return out


def test_layout_lists_every_module():
    listed = set().union(*layout_sections().values())
    unlisted, gone = sorted(lab_modules() - listed), sorted(listed - lab_modules())
    assert not unlisted, f"docs/layout.md does not list these modules (one table row each): {unlisted}"
    assert not gone, f"docs/layout.md lists modules that do not exist: {gone}"


def test_layout_lists_each_module_in_its_stage():
    # A section's heading names where its modules are: a subpackage's folder ("### Data
    # (`lab/data/`)"), a module directly under lab/ ("(`lab/course.py`)"), or `lab/` itself.
    misplaced = []
    for heading, paths in layout_sections().items():
        places = set(re.findall(r"`(lab/[\w./]*)`", heading))
        for path in paths:
            parts = path.split("/")
            home = {f"lab/{parts[1]}/"} if len(parts) > 2 else {path, "lab/"}
            if not home & places:
                misplaced.append(f"{path} under {heading!r}")
    assert not misplaced, "docs/layout.md lists modules outside their stage: " + "; ".join(misplaced)


def test_architecture_layers_are_the_checked_ones():
    table = section(ARCHITECTURE.read_text(), "The layers")
    layers = re.findall(r"^\| `([\w]+)` \|", table, re.M)
    assert layers == LAYERS, f"docs/design/architecture.md lists the layers {layers}, tests/test_layers.py {LAYERS}"


def test_moved_names_are_gone_and_their_new_homes_exist():
    problems = []
    for row in re.findall(r"^\|(.+)\|(.+)\|$", section(ARCHITECTURE.read_text(), MOVED_HEADING), re.M):
        (old_names, old_paths), (new_names, new_paths) = quoted(row[0]), quoted(row[1])
        problems += [f"{n} still exists" for n in old_names if resolves(n)]
        problems += [f"{p} still exists" for p in old_paths if (ROOT / p).exists()]
        problems += [f"{n} does not exist" for n in new_names if not resolves(n)]
        problems += [f"{p} does not exist" for p in new_paths if not (ROOT / p).exists()]
    assert not problems, "docs/design/architecture.md, what moved where: " + "; ".join(problems)


#: Module-level ``MAX_*`` constants that are not limits on what a user asks for.
NOT_LIMITS = {"lab.control.dfo.MAX_STEP_REL"}  # the derivative-free IK's largest step, a scale


def declared_limits() -> set[str]:
    """Every module-level ``MAX_*`` constant of the package, as ``lab.module.NAME``."""
    out = set()
    for path in (ROOT / "lab").rglob("*.py"):
        module = ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Assign):
                targets = node.targets
            elif isinstance(node, ast.AnnAssign):
                targets = [node.target]
            else:
                continue
            out |= {f"{module}.{t.id}" for t in targets if isinstance(t, ast.Name) and t.id.startswith("MAX_")}
    return out - NOT_LIMITS


def test_safety_page_lists_every_limit():
    text = section((ROOT / "docs" / "safety.md").read_text(), "Limits")
    missing = sorted(name for name in declared_limits() if f"`{name}`" not in text)
    assert not missing, f"docs/safety.md's Limits table does not name {missing}"
