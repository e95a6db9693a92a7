"""The documentation site (scripts/docs) builds without a warning and every page holds.

One build per test session (``site``: scripts/docs into a temporary folder, never
build/docs/; or the site ``LAB_DOCS_SITE`` names, built elsewhere), then: no warning
(``-W``, ``-n``: every cross-reference resolves); every internal link of the built HTML
names a file that exists and an anchor in it; every public name of every module's
``__all__`` has an API entry; and Chromium, with no network, shows the front page, a chapter
with its figure (an image that loaded), the API entry of ``lab.fem.solve_static`` with its
signature, and the built-in search finds it; every chapter's formulas are typeset by the
site's own copy of MathJax, with its fonts, and no raw TeX is left; the sidebar lists each
page once (chapter 04's "Part 2" is no course entry). The recorded chapters show every
output their text refers to: each ``plt.show()`` an image, each widget and 3-D scene a
static view (never ``VBox(children=...)``), each exercise the solution its grader passed;
every results page shows a figure; in Chromium every image loads and nothing reaches past
the content column. Without the build: every chapter has a recorded run in
figures/notebooks/ (scripts/record_notebooks.py, run by scripts/reproduce) that is small,
and the recorder keeps what the site needs (a small synthetic executed chapter).
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


#: The recorded runs together stay small in git (bytes; measured: 0.6 MB before they kept the plots cells
#: only show, the sliders' images and the 3-D stills; 1.3 MB recorded from a quick run with them).
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


def _display(data):
    return {"output_type": "display_data", "metadata": {}, "data": data}


def _result(data):
    return {"output_type": "execute_result", "execution_count": 1, "metadata": {}, "data": data}


def _grade(line):
    return _display({"text/html": f"<b>{line}</b>", "text/plain": line})


def _code(cell_id, source, outputs, tags=()):
    cell = {"cell_type": "code", "id": cell_id, "metadata": {"tags": list(tags)}, "execution_count": 1}
    return {**cell, "source": source, "outputs": outputs}


def _noise_png():
    """A PNG far over the size rule (base64): 500 x 500 pixels of noise."""
    import base64
    import io

    import numpy as np
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.random.default_rng(0).integers(0, 256, (500, 500, 3), dtype=np.uint8)).save(buf, "PNG")
    return base64.b64encode(buf.getvalue()).decode("ascii")


#: A widget's view (needs a kernel) and its text.
_WIDGET = {"application/vnd.jupyter.widget-view+json": {"model_id": "1"}, "text/plain": "VBox(children=(FloatSlider("}


def _executed(tmp_path):
    """A small executed chapter: a figure saved and drawn inline, a plot only shown, widgets
    with and without their image, 3-D scenes with and without a still, an exercise."""
    big = "<div>" + "x" * 300_000 + "</div>"
    still = "iVBOR" + "A" * 1000  # a small PNG, as base64
    cells = [
        {"cell_type": "markdown", "id": "t", "metadata": {}, "source": "# 99 A chapter"},
        _code("s", 'def twice(x):\n    """Two x."""\n    return 2 * x\n', [], tags=["solution"]),
        _code("g", "check_twice(twice)", [_grade("exercise 'twice': passed (3 random cases)")], tags=["grader"]),
        _code(
            "f",
            'fig.savefig(os.path.join(figures_dir, "fig_a.png"))\nprint("wrote", path)\nplt.show()',
            [
                {"output_type": "stream", "name": "stdout", "text": "wrote ../figures/fig_b.png\n"},
                _image("AAAA"),
                _image("BBBB"),
                _image("CCCC"),
            ],
        ),
        _code("p", "ax.loglog(h, err)\nplt.show()", [_image("PLOT")]),
        _code("w", "explorer.widget()", [_result({**_WIDGET, "image/png": still})]),
        _code("v", "old_widget()", [_result(dict(_WIDGET))]),
        _code("a", "show_arm(fem, q)", [_display({"text/html": big, "image/png": still, "text/plain": "<arm>"})]),
        _code("h", "scene", [_display({"text/html": big, "text/plain": "scene"})]),
        _code(
            "m",
            'open(os.path.join(figures_dir, "anim.html"), "w").write(page)\nshow_animation(page, fem, q_frames)',
            [_display({"text/html": big, "image/png": still})],
        ),
        _code("b", "plt.show()", [_image("B" * 300_000)]),
        _code("n", "plt.imshow(noise)\nplt.show()", [_image(_noise_png())]),
    ]
    cells[3]["metadata"]["papermill"] = {"duration": 1.0}  # (a run's timing: dropped)
    meta = {"papermill": {"parameters": {"quick": False}, "start_time": "2026-11-26T10:00:00"}}
    nb = {"cells": cells, "metadata": meta, "nbformat": 4, "nbformat_minor": 5}
    (tmp_path / "build").mkdir()
    path = tmp_path / "build" / "99_chapter.ipynb"
    path.write_text(json.dumps(nb))
    figures = tmp_path / "figures"
    figures.mkdir()
    for name in ("fig_a.png", "fig_b.png", "anim.html"):
        (figures / name).write_bytes(b"\x89PNG")
    return path, figures


def _recorded(tmp_path):
    record = _load_script("record_notebooks")
    executed, figures = _executed(tmp_path)
    assert record.main(["--figures", str(figures), "--out", str(figures / "notebooks"), str(executed)]) == 0
    nb = json.loads((figures / "notebooks" / "99_chapter.ipynb").read_text())
    return nb, {c["id"]: c for c in nb["cells"]}, record


def _shown(out):
    """What the site renders of an output: its richest representation (MyST-NB's order)."""
    data = out.get("data", {})
    for kind in ("text/html", "image/png", "text/markdown", "text/plain"):
        if kind in data:
            return kind, "".join(data[kind])
    return "stream", "".join(out.get("text", ""))


def test_recorded_copy_refers_to_saved_figures(tmp_path):
    nb, cells, _ = _recorded(tmp_path)
    assert nb["cells"][1]["id"] == "recorded-run" and "full mode, 2026-11-26" in nb["cells"][1]["source"]
    assert "papermill" not in cells["f"]["metadata"]
    outs = cells["f"]["outputs"]
    # the two inline images of the two saved figures are references now; the third image stays
    assert [o["data"].get("image/png") for o in outs if "data" in o] == ["CCCC", None, None]
    assert [o["data"]["text/markdown"] for o in outs[-2:]] == [
        "![fig_a.png](../fig_a.png)",
        "![fig_b.png](../fig_b.png)",
    ]


def test_recorded_copy_keeps_every_image_the_text_refers_to(tmp_path):
    """A plot a cell only shows keeps its image, made smaller if it is over the size rule; a
    widget becomes the image it drew (or a line, never its ``VBox(children=...)`` text); a 3-D
    scene too large to keep shows its still; an exercise shows the reference solution the
    grader passed, folded; an output over the size rule with nothing smaller beside it is a
    line saying so."""
    nb, cells, record = _recorded(tmp_path)
    assert _shown(cells["p"]["outputs"][0]) == ("image/png", "PLOT")  # plt.show(), nothing saved
    image, note = cells["w"]["outputs"]  # the sliders: their image, and a line on what is left out
    assert image["data"]["image/png"].startswith("iVBOR") and record.KERNEL_ONLY[0] not in image["data"]
    assert "interactive widget" in _shown(note)[1] and "the image it drew" in _shown(note)[1]
    (only,) = cells["v"]["outputs"]  # a widget with nothing but its text: a line instead
    assert _shown(only)[0] == "text/markdown" and "run the chapter in JupyterLab" in _shown(only)[1]
    scene, note = cells["a"]["outputs"]  # the scene's 0.3 MB of HTML go, its still stays
    assert _shown(scene)[0] == "image/png" and "text/html" not in scene["data"]
    assert "still image of an output of 0.3 MB (text/html)" in note["data"]["text/markdown"]
    (only,) = cells["h"]["outputs"]  # no still: a line stands in
    assert "0.3 MB (text/html) is left out of the recorded copy" in _shown(only)[1]
    # an animation saved as a page of its own keeps its still (only a saved PNG is a duplicate)
    kinds = [_shown(o)[0] for o in cells["m"]["outputs"]]
    assert kinds == ["image/png", "text/markdown", "text/markdown"], kinds
    assert "anim.html" in _shown(cells["m"]["outputs"][-1])[1]
    (only,) = cells["b"]["outputs"]  # an image over the rule (base64: 300 kB) that is no PNG
    assert "0.3 MB (image/png) is left out" in _shown(only)[1]
    (plot,) = cells["n"]["outputs"]  # a real PNG over the rule (1 MB): made smaller, it stays
    kind, png = _shown(plot)
    assert kind == "image/png" and png.startswith("iVBOR") and len(png) <= record.MAX_OUTPUT_BYTES
    sizes = [len(json.dumps(v)) for c in nb["cells"] for o in c.get("outputs", []) for v in o.get("data", {}).values()]
    assert max(sizes) <= record.MAX_OUTPUT_BYTES + 2  # (its quotes)
    # the exercise: the reference solution that passed, folded (MyST-NB's hide-input), never a stub
    solution = cells["s"]
    assert "return 2 * x" in solution["source"] and "NotImplementedError" not in solution["source"]
    assert "hide-input" in solution["metadata"]["tags"]
    assert solution["metadata"]["mystnb"]["code_prompt_show"] == "Show the reference solution"
    assert "passed" in _shown(cells["g"]["outputs"][0])[1]
    assert not [c["id"] for c in nb["cells"] for o in c.get("outputs", []) if "VBox(children=" in _shown(o)[1]]


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


def test_fuzzy_lookups_from_the_index_are_sphinxs():
    """docs/_ext/lab_fuzzy_index.py finds what the Python domain's own scan finds, in its order."""
    from sphinx.domains.python import ObjectEntry, PythonDomain

    sys.path.insert(0, str(ROOT / "docs" / "_ext"))
    try:
        indexed_class = importlib.import_module("lab_fuzzy_index").IndexedPythonDomain
    finally:
        sys.path.remove(str(ROOT / "docs" / "_ext"))
    names = ["lab.fem.ArmFEM", "lab.fem.ArmFEM.hessian", "lab.fem.solve.statics.solve_static", "lab.fem.solve_static"]
    names += ["lab.learn.train", "lab.learn.train_spec.TrainSpec", "lab.rig.ArmFEM", "ArmFEM", "lab.x.hessian"]
    kinds = ["class", "method", "function", "function", "function", "class", "data", "class", "attribute"]
    domains = []
    for cls in (PythonDomain, indexed_class):
        domain = object.__new__(cls)  # what find_obj reads: the objects and the roles' object types
        domain.data = {"objects": {n: ObjectEntry("page", n, k, False) for n, k in zip(names, kinds)}}
        domain._role2type = {}
        for kind, objtype in cls.object_types.items():
            for role in objtype.roles:
                domain._role2type.setdefault(role, []).append(kind)
        domain.object_types, domain.objtypes_for_role = dict(cls.object_types), domain._role2type.get
        domains.append(domain)
    asked = ["ArmFEM", "hessian", "solve_static", "statics.solve_static", "train", "TrainSpec", "nothing", "()"]
    asked += ["fem.ArmFEM.hessian", "ArmFEM.hessian()", "x.hessian", "lab.fem.ArmFEM"]
    for name in asked:
        for mod, cls_name in (("", ""), ("lab.fem", ""), ("lab.fem", "ArmFEM"), ("lab.rig", "")):
            for role in (None, "class", "func", "meth", "obj", "data"):
                for mode in (0, 1):
                    ours, theirs = (d.find_obj(None, mod, cls_name, name, role, mode) for d in (domains[1], domains[0]))
                    assert [n for n, _ in ours] == [n for n, _ in theirs], (name, mod, cls_name, role, mode)
    assert [n for n, _ in domains[1].find_obj(None, "", "", "ArmFEM", "class", 1)] == ["ArmFEM"]
    assert len(domains[1].find_obj(None, "", "", "hessian", None, 1)) == 2  # two objects end with .hessian


def test_docstring_math_and_command_blocks():
    lab_api = _lab_api()
    assert lab_api.plain_text_math(["mean |x - y| over ``a|b`` and :data:`A|B`"]) == [
        "mean \\|x - y\\| over ``a|b`` and :data:`A|B`"
    ]
    lines = ["Usage, for example", "", "    python -m lab train a.csv", "", "Text."]
    assert lab_api.command_blocks(lines) == ["Usage, for example", "", "::", "", *lines[2:]]
    assert lab_api.command_blocks(["Usage::", "", "    python -m lab x"]) == ["Usage::", "", "    python -m lab x"]


# ------------------------------------------------------------------ the build
#: A site built elsewhere to check instead of building one (its folder): e.g. one built from a
#: copy of the repository whose figures/notebooks/ hold copies recorded from a quick run.
SITE_ENV = "LAB_DOCS_SITE"


@pytest.fixture(scope="session")
def site(tmp_path_factory):
    """scripts/docs into a temporary folder: (the site's folder, stderr, seconds); or the site
    ``LAB_DOCS_SITE`` names, built elsewhere (stderr None: its warnings are not seen here)."""
    if os.environ.get(SITE_ENV):
        built = Path(os.environ[SITE_ENV]).resolve()
        assert (built / "README.html").is_file(), f"{SITE_ENV}={built}: no built site there"
        return built, None, 0.0
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
    if stderr is None:
        pytest.skip(f"{SITE_ENV}: a site built elsewhere (its build's warnings are not seen here)")
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


def test_an_api_page_lists_its_names_not_their_members(site):
    page = (site[0] / "docs" / "api" / "lab.fem.html").read_text()
    toc = page[page.index('class="toc-tree"') :]
    toc = toc[: toc.index("</div>")]  # the page's "On this page"
    assert 'href="#lab.fem.ArmFEM"' in toc and 'href="#lab.fem.solve_static"' in toc
    assert 'href="#lab.fem.ArmFEM.hessian"' not in toc and 'id="lab.fem.ArmFEM.hessian"' in page


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


# ------------------------------------------------------------------ every output the text refers to
# On the built site, from the recorded runs in figures/notebooks/ (scripts/reproduce writes them;
# LAB_DOCS_SITE checks a site built from other recorded copies): every plot, widget and 3-D scene
# shows an image, and each exercise the solution its grader passed.


class _Cells(HTMLParser):
    """The code cells of a built chapter page: each one's classes (MyST-NB's ``tag_*``), its
    source text, its outputs' text and the ``src`` of their images."""

    def __init__(self, text):
        super().__init__()
        self.cells, self._divs, self._cell_at, self._part = [], [], None, None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        classes = (attrs.get("class") or "").split()
        if tag == "div":
            self._divs.append(classes)
            if "cell" in classes and self._cell_at is None:
                self._cell_at = len(self._divs)
                self.cells.append({"classes": classes, "source": "", "output": "", "images": []})
            elif self._cell_at is not None and {"cell_input", "cell_output"} & set(classes):
                self._part = ("source" if "cell_input" in classes else "output", len(self._divs))
        elif tag == "img" and self._part and self._part[0] == "output":
            self.cells[-1]["images"].append(attrs.get("src", ""))

    def handle_endtag(self, tag):
        if tag != "div" or not self._divs:
            return
        depth = len(self._divs)
        self._divs.pop()
        if self._part and depth == self._part[1]:
            self._part = None
        if depth == self._cell_at:
            self._cell_at = None

    def handle_data(self, data):
        if self._part:
            self.cells[-1][self._part[0]] += data


#: A cell that shows a figure (pyplot's), a widget (sliders, the IK picker) or a 3-D scene.
_SHOWS_A_PLOT = re.compile(r"\bplt\.show\(\)")
_SHOWS_A_WIDGET = re.compile(r"\.widget\(")
_SHOWS_A_SCENE = re.compile(r"^(?!\s*(?:from|import)\b).*\bshow_(?:arm|animation)\(", re.M)


def _chapter_cells(out):
    """(chapter page, cell number, cell) of every code cell of every chapter of the site."""
    pages = sorted((out / "figures" / "notebooks").glob("[0-9][0-9]_*.html"))
    assert pages, f"no chapter pages in {out}"
    return [(page, k, cell) for page in pages for k, cell in enumerate(_Cells(page.read_text()).cells)]


def _where(page, k, cell):
    line = next((x for x in cell["source"].splitlines() if x.strip()), "")
    return f"{page.name} cell {k} ({line.strip()[:60]})"


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_every_plot_of_a_chapter_shows_its_image(site):
    """A cell that calls ``plt.show()`` has an image below it (papermill's kernels draw inline:
    under Agg plt.show() shows nothing, and only the figures a cell saved were shown)."""
    plots = [c for c in _chapter_cells(site[0]) if _SHOWS_A_PLOT.search(c[2]["source"])]
    missing = [_where(*c) for c in plots if not c[2]["images"]]
    assert not missing, f"{len(missing)} cells call plt.show() and show no image: {missing}"


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_widgets_and_3d_scenes_have_a_static_view(site):
    """The sliders and the IK picker show the image they drew, a 3-D scene its still (the arm's
    PNG, the animation's animated PNG); no page shows a widget's text (``VBox(children=...)``)."""
    cells = _chapter_cells(site[0])
    widgets = [c for c in cells if _SHOWS_A_WIDGET.search(c[2]["source"])]
    scenes = [c for c in cells if _SHOWS_A_SCENE.search(c[2]["source"])]
    names = {c[0].name[:2] for c in widgets}, {c[0].name[:2] for c in scenes}
    assert names[0] >= {"01", "04", "06"} and names[1] >= {"01", "06"}, f"chapters with widgets, with scenes: {names}"
    missing = [_where(*c) for c in widgets + scenes if not c[2]["images"]]
    assert not missing, f"widgets or 3-D scenes with no image: {missing}"
    # (every page: a page that quotes the repr should write it VBox(...))
    raw = [p.relative_to(site[0]).as_posix() for p in site[0].rglob("*.html") if "VBox(children=" in p.read_text()]
    assert not raw, f"pages that show a widget as its text: {raw}"


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_exercises_show_the_solution_their_grader_passed(site):
    """No exercise shows a stub (``raise NotImplementedError``) above its grader's "passed":
    the recorded run is the instructor's, so the reference solution is shown, folded."""
    solutions = [c for c in _chapter_cells(site[0]) if "tag_solution" in c[2]["classes"]]
    assert len({c[0].name for c in solutions}) >= 5, "chapters with exercises: fewer than five"
    stubs = [_where(*c) for c in solutions if "NotImplementedError" in c[2]["source"]]
    assert not stubs, f"exercises that show a stub: {stubs}"
    unfolded = [_where(*c) for c in solutions if "tag_hide-input" not in c[2]["classes"]]
    assert not unfolded, f"reference solutions shown unfolded: {unfolded}"


#: JavaScript: the blocks of the article cut off at the column: past the article's right edge,
#: or holding wider content without scrolling it (it spills over the edge, where the page clips).
_CUT_OFF = (
    "(() => { const article = document.querySelector('article');"
    " const right = article.getBoundingClientRect().right + 1;"
    ' const blocks = \'pre, div.highlight, div.math, mjx-container[display="true"], .table-wrapper, .cell_output,'
    "   img';"
    " const scrolls = e => ['auto', 'scroll'].includes(getComputedStyle(e).overflowX);"
    " return [...article.querySelectorAll(blocks)]"
    "   .filter(e => e.getBoundingClientRect().right > right || (e.scrollWidth > e.clientWidth + 1 && !scrolls(e)))"
    "   .map(e => `${e.tagName.toLowerCase()}.${e.className}: ${(e.textContent || e.src || '').slice(0, 60)}`); })()"
)
#: JavaScript: the article's images that did not load.
_BROKEN_IMAGES = "[...document.querySelectorAll('article img')].filter(i => !(i.naturalWidth > 0)).map(i => i.src)"


@pytest.mark.slow
@pytest.mark.browser
@pytest.mark.timeout(900)
def test_images_load_and_nothing_is_cut_off_in_chromium(site, tmp_path):
    """Every results page shows at least one figure and every image of a chapter or results
    page loads; no formula, code block or output reaches past the content column (what is
    wider scrolls inside its own block: docs/_static/site.css)."""
    require_chromium()
    out = site[0]
    results = sorted((out / "docs").glob("results-*.html"))
    chapters = sorted((out / "figures" / "notebooks").glob("[0-9][0-9]_*.html"))
    assert len(results) >= 8 and chapters, (results, chapters)
    problems = []
    with DevToolsPage(devtools_command(), tmp_path / "profile", width=1200, height=900) as page:
        for html in results + chapters:
            page.navigate(html.as_uri())
            ready = f"location.href.endsWith('{html.name}') && document.readyState === 'complete'"
            _wait(page, f"{ready} && [...document.images].every(i => i.complete)", 60, f"{html.name}")
            if page.evaluate("!!window.MathJax?.startup?.promise"):
                page.evaluate("MathJax.startup.promise.then(() => true)", await_promise=True)
            n_images = page.evaluate("document.querySelectorAll('article img').length")
            if html in results and n_images == 0:
                problems.append(f"{html.name}: no figure")
            problems += [f"{html.name}: {src} did not load" for src in page.evaluate(_BROKEN_IMAGES)]
            problems += [f"{html.name}: cut off at the column: {e}" for e in page.evaluate(_CUT_OFF)]
    assert not problems, f"{len(problems)} problems:\n" + "\n".join(problems[:40])
