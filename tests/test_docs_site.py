"""The documentation site (scripts/docs) builds without a warning and every page holds.

One build per test session (``site``: scripts/docs into a temporary folder, never
build/docs/), then: no warning (``-W``, ``-n``: every cross-reference resolves); every
internal link of the built HTML names a file that exists and an anchor in it; every public
name of every module's ``__all__`` has an API entry; and Chromium, with no network, shows
the front page, a chapter with its figure (an image that loaded), the API entry of
``lab.fem.solve_static`` with its signature, and the built-in search finds it; every
chapter's formulas are typeset by the site's own copy of MathJax, with its fonts, and no raw
TeX is left; the sidebar lists each page once (chapter 04's "Part 2" is no course entry).
Without the build: every chapter has a recorded run in figures/notebooks/ (scripts/record_notebooks.py,
run by scripts/reproduce) that is small, and the recorder keeps a cell's saved figure as a
reference to the committed file.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import os
import re
import subprocess
import sys
import time
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
from helpers import DevToolsPage, wait_until
from test_layers import SUBPACKAGES
from test_viz import devtools_command, require_chromium

ROOT = Path(__file__).resolve().parent.parent
RECORDED = ROOT / "figures" / "notebooks"
#: The modules with an API page: the shared ones, the description, every top-level subpackage
#: (a nested one, such as lab.fem.solve, is documented on its parent's page: see
#: test_nested_packages_export_through_their_parent).
API_MODULES = ["lab.errors", "lab.specs", "lab.files", "lab.workers", "lab.description"] + [
    f"lab.{s}" for s in SUBPACKAGES if "." not in s
]


def test_nested_packages_export_through_their_parent():
    # lab.fem.bodies's names are on lab.fem's API page, under the name a user imports.
    for nested in (s for s in SUBPACKAGES if "." in s):
        parent = importlib.import_module(f"lab.{nested.rpartition('.')[0]}")
        names = importlib.import_module(f"lab.{nested}").__all__
        missing = [n for n in names if n not in parent.__all__]
        assert not missing, f"lab.{nested} exports names its parent does not (no API entry): {missing}"


#: The recorded runs together stay small in git (bytes; measured: about 0.6 MB).
MAX_RECORDED_BYTES = 3_000_000


def _load_script(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# ------------------------------------------------------------------ without a build
def test_every_chapter_has_a_recorded_run():
    chapters = {p.name for p in (ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb")}
    recorded = {p.name for p in RECORDED.glob("*.ipynb")}
    assert chapters == recorded, (
        f"chapters without a recorded run: {sorted(chapters - recorded)}; recorded runs of no chapter: "
        f"{sorted(recorded - chapters)} (scripts/reproduce writes figures/notebooks/)"
    )
    total = sum(p.stat().st_size for p in RECORDED.glob("*.ipynb"))
    assert total <= MAX_RECORDED_BYTES, f"figures/notebooks/ holds {total / 1e6:.1f} MB"
    for path in RECORDED.glob("*.ipynb"):
        for cell in json.loads(path.read_text())["cells"]:
            for out in cell.get("outputs", []):
                text = out.get("data", {}).get("text/markdown", "")
                for ref in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", "".join(text)):
                    assert (path.parent / ref).is_file(), f"{path.name} shows {ref}, which does not exist"


def _image(png):
    return {"output_type": "display_data", "metadata": {}, "data": {"image/png": png, "text/plain": "<Figure>"}}


def _executed(tmp_path):
    """A small executed chapter: a figure saved and drawn inline, a widget, a huge output, a solution."""
    big = "<div>" + "x" * 300_000 + "</div>"
    cells = [
        {"cell_type": "markdown", "id": "t", "metadata": {}, "source": "# 99 A chapter"},
        {
            "cell_type": "code",
            "id": "s",
            "metadata": {"tags": ["solution"]},
            "execution_count": 1,
            "outputs": [],
            "source": 'def twice(x):\n    """Two x."""\n    return 2 * x\n',
        },
        {
            "cell_type": "code",
            "id": "f",
            "metadata": {"papermill": {"duration": 1.0}},
            "execution_count": 2,
            "source": 'fig.savefig(os.path.join(figures_dir, "fig_a.png"))\nprint("wrote", path)',
            "outputs": [
                {"output_type": "stream", "name": "stdout", "text": "wrote ../figures/fig_b.png\n"},
                _image("AAAA"),
                _image("BBBB"),
                _image("CCCC"),
            ],
        },
        {
            "cell_type": "code",
            "id": "w",
            "metadata": {},
            "execution_count": 3,
            "source": "scene",
            "outputs": [
                {
                    "output_type": "execute_result",
                    "execution_count": 3,
                    "metadata": {},
                    "data": {"application/vnd.jupyter.widget-view+json": {"model_id": "1"}, "text/plain": "Slider"},
                },
                {"output_type": "display_data", "metadata": {}, "data": {"text/html": big, "text/plain": "scene"}},
            ],
        },
    ]
    meta = {"papermill": {"parameters": {"quick": False}, "start_time": "2026-11-26T10:00:00"}}
    nb = {"cells": cells, "metadata": meta, "nbformat": 4, "nbformat_minor": 5}
    (tmp_path / "build").mkdir()
    path = tmp_path / "build" / "99_chapter.ipynb"
    path.write_text(json.dumps(nb))
    figures = tmp_path / "figures"
    figures.mkdir()
    for name in ("fig_a.png", "fig_b.png"):
        (figures / name).write_bytes(b"\x89PNG")
    return path, figures


def test_recorded_copy_refers_to_saved_figures(tmp_path):
    record = _load_script("record_notebooks")
    executed, figures = _executed(tmp_path)
    assert record.main(["--figures", str(figures), "--out", str(figures / "notebooks"), str(executed)]) == 0
    nb = json.loads((figures / "notebooks" / "99_chapter.ipynb").read_text())
    cells = {c["id"]: c for c in nb["cells"]}
    assert nb["cells"][1]["id"] == "recorded-run" and "full mode, 2026-11-26" in nb["cells"][1]["source"]
    assert "return 2 * x" not in cells["s"]["source"] and "NotImplementedError" in cells["s"]["source"]
    assert "papermill" not in cells["f"]["metadata"]
    outs = cells["f"]["outputs"]
    # the two inline images of the two saved figures are references now; the third image stays
    assert [o["data"].get("image/png") for o in outs if "data" in o] == ["CCCC", None, None]
    assert [o["data"]["text/markdown"] for o in outs[-2:]] == [
        "![fig_a.png](../fig_a.png)",
        "![fig_b.png](../fig_b.png)",
    ]
    widget, scene = cells["w"]["outputs"]
    assert widget["data"] == {"text/plain": "Slider"}
    assert "left out of the recorded copy" in scene["data"]["text/markdown"] and "0.3 MB" in scene["data"]["text/plain"]


def test_recorded_copies_name_no_machine_path():
    """The committed recorded runs show paths in the repository, not on the machine that ran them."""
    record = _load_script("record_notebooks")
    root = str(ROOT.resolve())
    out = record._without_root({"output_type": "stream", "name": "stdout", "text": [f"figures -> {root}/figures\n"]})
    assert out["text"] == ["figures -> <repository>/figures\n"]
    leaks = [p.name for p in sorted((ROOT / "figures" / "notebooks").glob("*.ipynb")) if root in p.read_text()]
    assert not leaks, f"recorded copies with this checkout's path {root}: {leaks}"


def test_recorder_refuses_to_overwrite_its_input(tmp_path, capsys):
    record = _load_script("record_notebooks")
    executed, figures = _executed(tmp_path)
    assert record.main(["--figures", str(figures), "--out", str(executed.parent), str(executed)]) == 2
    assert "would overwrite its input" in capsys.readouterr().err
    bad = tmp_path / "bad.ipynb"
    bad.write_text("{")
    assert record.main(["--figures", str(figures), "--out", str(tmp_path / "o"), str(bad)]) == 2
    assert "bad.ipynb: not an executed notebook" in capsys.readouterr().err


def _lab_api():
    """docs/_ext/lab_api.py, the site's API extension."""
    sys.path.insert(0, str(ROOT / "docs" / "_ext"))
    try:
        return importlib.import_module("lab_api")
    finally:
        sys.path.remove(str(ROOT / "docs" / "_ext"))


def test_docstring_math_and_command_blocks():
    lab_api = _lab_api()
    assert lab_api.plain_text_math(["mean |x - y| over ``a|b`` and :data:`A|B`"]) == [
        "mean \\|x - y\\| over ``a|b`` and :data:`A|B`"
    ]
    lines = ["Usage, for example", "", "    python -m lab train a.csv", "", "Text."]
    assert lab_api.command_blocks(lines) == ["Usage, for example", "", "::", "", *lines[2:]]
    assert lab_api.command_blocks(["Usage::", "", "    python -m lab x"]) == ["Usage::", "", "    python -m lab x"]


# ------------------------------------------------------------------ the build
@pytest.fixture(scope="session")
def site(tmp_path_factory):
    """scripts/docs into a temporary folder: (the site's folder, stderr, seconds)."""
    out = tmp_path_factory.mktemp("site") / "docs"
    env = {**os.environ, "LAB_DOCS_OUT": str(out), "LAB_DOCS_JOBS": "1"}
    t0 = time.perf_counter()
    run = subprocess.run(["bash", str(ROOT / "scripts" / "docs")], cwd=ROOT, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    assert run.returncode == 0, f"scripts/docs failed (exit {run.returncode}):\n{run.stderr[-6000:]}"
    return out, run.stderr, seconds


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_build_gives_no_warning(site):
    out, stderr, seconds = site
    print(f"site built in {seconds:.0f} s")
    assert not re.search(r"WARNING|ERROR", stderr), stderr[-6000:]
    assert (out / "index.html").is_file() and (out / "README.html").is_file()


class _Page(HTMLParser):
    """The ids of an HTML page and the links (href, src) it makes."""

    def __init__(self, text):
        super().__init__()
        self.ids, self.links = set(), []
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if attrs.get("id"):
            self.ids.add(attrs["id"])
        if tag == "a" and attrs.get("name"):
            self.ids.add(attrs["name"])
        for key in ("href", "src"):
            if attrs.get(key) and not (tag == "iframe" and key == "src" and attrs[key].startswith("about:")):
                self.links.append(attrs[key])


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_internal_links_resolve(site):
    out = site[0]
    pages = {p: _Page(p.read_text(errors="replace")) for p in out.rglob("*.html")}
    problems = []
    for page, parsed in pages.items():
        for link in parsed.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith("#") and not link[1:]:
                continue  # another site (http:, mailto:, data:), or a bare "#"
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            if not target.is_file():
                problems.append(f"{page.relative_to(out)}: {link} (no such file)")
            elif parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _Page(target.read_text()).ids
                if unquote(parts.fragment) not in ids:
                    problems.append(f"{page.relative_to(out)}: {link} (no such anchor)")
    assert not problems, f"{len(problems)} broken links, e.g.:\n" + "\n".join(problems[:30])


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_every_public_name_has_an_api_entry(site):
    out = site[0]
    missing = []
    for modname in API_MODULES:
        page = out / "docs" / "api" / f"{modname}.html"
        assert page.is_file(), f"no API page for {modname} (docs/api/{modname}.rst)"
        ids = _Page(page.read_text()).ids
        names = _lab_api().public_names(importlib.import_module(modname))  # __all__ (lab.description: its own)
        missing += [f"{modname}.{n}" for n in names if f"{modname}.{n}" not in ids]
    assert not missing, f"{len(missing)} public names have no API entry: {missing[:20]}"


def _wait(page, expression, timeout_s, what):
    """``page.wait_for``, through navigations (a page being replaced answers nothing)."""

    def holds():
        try:
            return page.evaluate(expression)
        except AssertionError:  # the execution context went with the old page
            return False

    wait_until(holds, timeout_s, what)


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.timeout(900)
def test_pages_and_search_in_chromium(site, tmp_path):
    require_chromium()
    out = site[0]
    command = devtools_command()
    loaded = "document.readyState === 'complete'"
    with DevToolsPage(command, tmp_path / "profile", width=1200, height=900) as page:
        page.navigate((out / "index.html").as_uri())  # redirects to the front page
        _wait(page, f"location.href.endsWith('README.html') && {loaded}", 60, "the front page")
        assert "Quick start" in page.evaluate("document.body.innerText")

        page.navigate((out / "figures" / "notebooks" / "01_fem_simulation.html").as_uri())
        _wait(page, f"location.href.endsWith('01_fem_simulation.html') && {loaded}", 60, "chapter 01")
        figures = "[...document.images].filter(i => i.src.includes('fig1_setup'))"
        _wait(page, f"{figures}.length > 0 && {figures}.every(i => i.complete)", 60, "chapter 01's figure")
        assert page.evaluate(f"{figures}[0].naturalWidth") > 100, "chapter 01's Figure 1 did not load"

        page.navigate((out / "docs" / "api" / "lab.fem.html").as_uri())
        _wait(page, f"location.href.endsWith('lab.fem.html') && {loaded}", 60, "the lab.fem API page")
        signature = page.evaluate("document.getElementById('lab.fem.solve_static')?.innerText")
        assert signature and re.search(r"lab\.fem\.solve_static\(\s*fem", signature), signature

        page.navigate((out / "search.html").as_uri())  # type the query into the search box, press Enter
        _wait(
            page,
            f"location.href.endsWith('search.html') && {loaded} && !!document.querySelector('input[name=q]')",
            60,
            "the search page",
        )
        page.evaluate("document.querySelector('input[name=q]').focus(), true")
        page.call("Input.insertText", text="solve_static")
        enter = {"key": "Enter", "code": "Enter", "windowsVirtualKeyCode": 13}
        page.call("Input.dispatchKeyEvent", type="keyDown", text="\r", **enter)
        page.call("Input.dispatchKeyEvent", type="keyUp", **enter)
        hits = "[...document.querySelectorAll('#search-results a')].map(a => a.href)"
        _wait(
            page,
            f"location.search.includes('q=solve_static') && {hits}.some(h => h.includes('docs/api/lab.fem.html'))",
            60,
            "a search hit on lab.fem",
        )


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_sidebar_lists_each_page_once(site):
    """A page's second top-level heading (chapter 04's "Part 2") is no entry of its own."""
    sidebar = (site[0] / "README.html").read_text()
    entries = re.findall(r'<li class="toctree-l1[^"]*"><a class="reference internal" href="([^"]+)"', sidebar)
    assert any(e.endswith("04_trajectory_following.html") for e in entries), entries
    assert not [e for e in entries if "#" in e], f"sidebar entries that are a heading of a page: {entries}"
    chapter = (site[0] / "figures" / "notebooks" / "04_trajectory_following.html").read_text()
    part2 = re.search(r'id="part-2-the-real-emulated-as-built-robot">\s*(<span [^>]*></span>)?<h(\d)', chapter)
    assert part2 and part2[2] == "2", "chapter 04's Part 2 is no subsection of the page's title"
    assert chapter.count("<h1") == 1


#: JavaScript: [formulas on the page, formulas MathJax typeset, its errors].
_MATH_COUNTS = (
    "[...['article .math', 'article mjx-container', 'mjx-merror']].map(s => document.querySelectorAll(s).length)"
)
#: JavaScript: the article's text outside code and typeset formulas (where raw TeX would show).
_PROSE = (
    "(() => { const a = document.querySelector('article').cloneNode(true);"
    " a.querySelectorAll('pre, code, mjx-container').forEach(e => e.remove()); return a.textContent; })()"
)
#: Raw TeX in prose: a \( or \[ delimiter, or a pair of dollars.
_RAW_TEX = re.compile(r"\\[(\[]|\$\$|\$[^$\s][^$]*\$")


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.timeout(900)
def test_math_renders_offline_in_chromium(site, tmp_path):
    """Every chapter's formulas typeset by the site's own MathJax 3 and its fonts, none left raw."""
    require_chromium()
    out = site[0]
    command = devtools_command()
    mathjax = (out / "_static" / "mathjax" / "tex-chtml-full.js").as_uri()
    pages = sorted((out / "figures" / "notebooks").glob("[0-9][0-9]_*.html"))
    chapters = [p for p in pages if 'class="math' in p.read_text()]  # MathJax is on pages with math only
    assert "04_trajectory_following.html" in [p.name for p in chapters], [p.name for p in pages]
    with DevToolsPage(command, tmp_path / "profile", width=1200, height=900) as page:
        for chapter in chapters:
            page.navigate(chapter.as_uri())
            started = f"location.href.endsWith('{chapter.name}') && document.readyState === 'complete'"
            _wait(page, f"{started} && !!window.MathJax?.startup?.promise", 60, f"MathJax on {chapter.name}")
            assert page.evaluate("MathJax.startup.promise.then(() => MathJax.version)", await_promise=True) == "3.2.2"
            scripts = page.evaluate("[...document.scripts].map(s => s.src).filter(s => /mathjax/i.test(s))")
            assert scripts == [mathjax], f"{chapter.name} loads MathJax from {scripts}"
            _wait(page, f"(([m, t]) => m > 0 && t === m)({_MATH_COUNTS})", 60, f"every formula of {chapter.name}")
            assert page.evaluate(_MATH_COUNTS)[2] == 0, f"a formula of {chapter.name} failed to typeset"
            prose = page.evaluate(_PROSE)
            raw = [prose[max(0, m.start() - 40) : m.end() + 40] for m in _RAW_TEX.finditer(prose)]
            assert not raw, f"{chapter.name}: {len(raw)} formulas show as raw TeX, e.g. {raw[:3]}"
            if chapter.name.startswith("04_"):  # the objective O(u) of its goals, in MathJax's own fonts
                formulas = "[...document.querySelectorAll('article mjx-container')].map(e => e.textContent)"
                typeset = page.evaluate(formulas)
                assert any(f.startswith("O(u)=") for f in typeset), typeset[:8]
                loaded = "[...document.fonts].filter(f => f.status === 'loaded').map(f => f.family)"
                fonts = page.evaluate(f"document.fonts.ready.then(() => {loaded})", await_promise=True)
                assert "MJXTEX" in fonts, f"MathJax's fonts did not load from _static/: {fonts}"
