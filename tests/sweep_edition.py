"""Fault-sweep rows (tests/sweep.py format) for ``python -m lab.course student-edition``: the
student edition built from chapters whose solution cells are not plain Python, or are not
cells at all, and rebuilt over notebooks JupyterLab saved.

Each setup writes ``nb/01_a.ipynb`` (a small chapter, tests/data/jupyterlab_saves/) with
its solution cell replaced; the edition goes to ``st/``. The rows with a rebuild first
build ``st/`` from the chapter, then put one of JupyterLab's saves of that edition in its
place and change the chapter. The cases where a save lands during the rebuild, the
command's Ctrl-C while it starts and ``scripts/jupyter --student``'s refusals need a hook
or a shell script: they are in tests/test_course_edition.py.
"""

import json
from pathlib import Path

from sweep import Case

ROOT = Path(__file__).resolve().parent.parent
SAVES = ROOT / "tests" / "data" / "jupyterlab_saves"
BUILD = ["student-edition", "--notebooks", "{dir}/nb", "--out", "{dir}/st"]


def _chapter(d: Path, solution=None, cells=None, title: str = "Doubling") -> None:
    nb = json.loads((SAVES / "source.json").read_text().replace("01 — Doubling", f"01 — {title}"))
    if solution is not None:
        next(c for c in nb["cells"] if "solution" in c["metadata"].get("tags", []))["source"] = solution
    if cells is not None:
        nb["cells"] = cells
    (d / "nb").mkdir(exist_ok=True)
    (d / "nb" / "01_a.ipynb").write_text(json.dumps(nb))


def _with(**kw):
    return lambda d: _chapter(d, **kw)


def _saved_by_jupyterlab(fixture: str):
    """st/ built, then JupyterLab's save ``fixture`` in place of 01_a.ipynb, then the chapter changed."""

    def setup(d: Path):
        from lab.course.edition import build_student_edition

        _chapter(d)
        build_student_edition(d / "nb", d / "st")
        (d / "st" / "01_a.ipynb").write_text((SAVES / fixture).read_text())
        _chapter(d, title="Doubling, v2")

    return setup


def _stub_of_f(d: Path) -> None:
    cells = json.loads((d / "st" / "01_a.ipynb").read_text())["cells"]
    stub = "".join(next(c for c in cells if "solution" in c["metadata"].get("tags", []))["source"])
    assert stub.startswith("def f(x):") and "NotImplementedError" in stub and "%" not in stub, stub


def _refreshed(d: Path) -> None:
    assert "v2" in (d / "st" / "01_a.ipynb").read_text() and not list((d / "st").glob("*.updated*"))


def _kept_and_beside(d: Path) -> None:
    assert (d / "st" / "01_a.ipynb").read_text() == (SAVES / "edited.json").read_text()
    assert "v2" in (d / "st" / "01_a.updated.ipynb").read_text()


MAGIC = "%matplotlib inline\ndef f(x):\n    '''Twice x.'''\n    return 2 * x\n"
NOT_WRITTEN = ("{dir}/st/01_a.ipynb",)


def _row(id: str, code: int, words: tuple = (), **kw) -> Case:
    return Case(id, BUILD, code, words, module="lab.course", **kw)


EDITION_CASES = [
    _row("edition-solution-magic", 0, setup=_with(solution=MAGIC), after=_stub_of_f),
    _row("edition-solution-cell-magic", 0, setup=_with(solution="%%time\n" + MAGIC[19:]), after=_stub_of_f),
    _row(
        "edition-solution-syntax-error",
        2,
        ("01_a.ipynb: a solution cell is not Python (line 2",),
        setup=_with(solution="def f(x):\n    return (x\n"),
        absent=NOT_WRITTEN,
    ),  # fmt: skip
    _row(
        "edition-solution-nul",
        2,
        ("01_a.ipynb: a solution cell is not Python",),
        setup=_with(solution="def f(x):\n\x00\n"),
        absent=NOT_WRITTEN,
    ),  # fmt: skip
    _row(
        "edition-cell-without-type",
        2,
        ("01_a.ipynb: not a notebook",),
        setup=_with(cells=[{"source": "x"}]),
        absent=NOT_WRITTEN,
    ),  # fmt: skip
    _row(
        "edition-cell-not-an-object",
        2,
        ("01_a.ipynb: not a notebook",),
        setup=_with(cells=["x = 1"]),
        absent=NOT_WRITTEN,
    ),  # fmt: skip
    _row(
        "edition-opened-by-jupyterlab-refreshed",
        0,
        ("1 refreshed",),
        setup=_saved_by_jupyterlab("opened.json"),
        after=_refreshed,
    ),  # fmt: skip
    _row(
        "edition-run-in-jupyterlab-refreshed",
        0,
        ("1 refreshed",),
        setup=_saved_by_jupyterlab("ran.json"),
        after=_refreshed,
    ),  # fmt: skip
    _row(
        "edition-edited-in-jupyterlab-kept",
        0,
        ("kept as it is", "01_a.updated.ipynb"),
        setup=_saved_by_jupyterlab("edited.json"),
        after=_kept_and_beside,
    ),  # fmt: skip
]
