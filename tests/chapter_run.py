"""One quick run of a chapter, shared by its three checks.

Three tests look at each chapter running in quick mode: ``test_notebooks.py`` (no cell
fails, every grader passes, every computed statement renders, figures are written),
``test_nbval.py`` (the headline numbers are the stored ones) and ``test_exercises.py``
(the student edition runs and its graders say "not implemented yet"). They used to execute
the chapter three times. :meth:`ChapterRuns.get` executes it once per pytest process and
keeps what each of them needs (:class:`ChapterRun`):

- papermill injects the parameters (``quick=True``, a temporary ``figures_dir``; the same
  prepared notebook nbval ran) and nbclient, papermill's engine, executes the cells in
  order in one kernel of the interpreter running pytest, from ``notebooks/``, each cell
  within :data:`helpers.CELL_TIMEOUT_S`, stopping at the first that fails;
- the kernel's messages for the cells nbval checks are kept as nbval keeps them
  (``nbval_outputs``);
- the files the kernel opens or lists by a path relative to its working folder are recorded
  (an audit hook), since the student edition runs from another folder;
- then, in the same kernel, the student edition's stubs, graders and the cells that depend
  on them run once more (``student_replay``), when that is shown to stand for the
  edition's own run.

Under pytest-xdist the three checks of a chapter must run in one worker, or each worker
runs the chapter: ``tests/conftest.py`` schedules them together (:func:`chapter_of`).
"""

from __future__ import annotations

import ast
import hashlib
import json
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import ipykernel.kernelspec
import nbformat
from helpers import CELL_TIMEOUT_S, output_text
from jupyter_client.kernelspec import KernelSpecManager
from jupyter_client.manager import AsyncKernelManager
from nbclient import NotebookClient
from nbval_outputs import nbval_options, nbval_output
from student_replay import Plan, replay_plan
from traitlets import default

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS_DIR = ROOT / "notebooks"
STUDENT_DIR = ROOT / "build" / "student"
#: the tests that read a chapter's shared run; xdist keeps them on one worker per chapter
SHARED_CHECKS = ("test_notebook_runs", "test_headline_numbers", "test_student_edition_runs_and_says_not_implemented")
_NODEID = re.compile(r"::(" + "|".join(SHARED_CHECKS) + r")\[(\d\d_[\w-]+\.ipynb)\]$")

# Records every path opened or listed relative to the working folder (but for the import
# system's looks along sys.path, which holds "": a module found there is listed at the end),
# with the cell's execution count, outside the user's namespace (a module of its own).
_AUDIT = """
def _lab_test_audit():
    import json, os, sys, types
    ip, seen = get_ipython(), types.ModuleType("_lab_test_audit")
    paths = []
    def hook(event, args):
        if event in ("open", "os.listdir", "os.scandir", "glob.glob", "os.chdir") and args:
            path = os.fsdecode(args[0]) if isinstance(args[0], (str, bytes)) else None
            if path is not None and not os.path.isabs(path) and not from_importlib(sys._getframe(1)):
                paths.append((ip.execution_count, event, path))
    def from_importlib(frame):
        while frame is not None:
            name = frame.f_code.co_filename
            if name.startswith(("<frozen importlib", "<frozen zipimport")) or f"{os.sep}importlib{os.sep}" in name:
                return True
            frame = frame.f_back
        return False
    def report():
        here = os.getcwd() + os.sep
        files = [getattr(m, "__file__", None) for m in list(sys.modules.values())]
        found = [(None, "import", f) for f in files if isinstance(f, str) and os.path.abspath(f).startswith(here)]
        return json.dumps(paths + found)
    seen.report = report
    sys.modules["_lab_test_audit"] = seen
    sys.addaudithook(hook)
_lab_test_audit()
del _lab_test_audit
"""
_AUDITED = "__import__('sys').modules['_lab_test_audit'].report()"


def chapter_of(nodeid: str) -> str | None:
    """The chapter whose shared run the test ``nodeid`` reads, or ``None``.

    Parameters
    ----------
    nodeid : str
        A pytest node id, ``tests/test_nbval.py::test_headline_numbers[05_sim_to_real.ipynb]``.

    Returns
    -------
    str or None
        The notebook's file name.
    """
    m = _NODEID.search(nodeid)
    return m.group(2) if m else None


@dataclass
class ChapterRun:
    """What a chapter's run left for its checks (indices: cells of the prepared notebook,
    which has papermill's injected-parameters cell after the parameters cell)."""

    name: str
    executed: nbformat.NotebookNode  # the cells as run (outputs as papermill keeps them)
    prepared: nbformat.NotebookNode  # the cells as stored (nbval's reference outputs)
    error: str = ""  # the first failure: the cell and its traceback
    ran: int = 0  # the cells before the first failure (all, without one)
    figures: list[str] = field(default_factory=list)  # files in figures_dir after the run
    checked: dict[int, list[dict]] = field(default_factory=dict)  # nbval's outputs per checked cell
    relative: list[tuple] = field(default_factory=list)  # (execution count, event, path) opened relative
    plan: Plan = Plan(None, "not planned")
    edition_sha256: str = ""  # the student edition the plan was made for
    replay: list[dict] = field(default_factory=list)  # {"index", "kind", "text", "error"} per cell replayed


class _ThisInterpreter(KernelSpecManager):
    """Kernel specs with one kernel: this interpreter (as nbval's ``--nbval-current-env``),
    whatever kernel specs the machine has."""

    def get_kernel_spec(self, kernel_name):
        return self.kernel_spec_class(
            resource_dir=ipykernel.kernelspec.RESOURCES, **ipykernel.kernelspec.get_kernel_dict()
        )


class _Manager(AsyncKernelManager):
    @default("kernel_spec_manager")
    def _this_interpreter(self):
        return _ThisInterpreter()


class _Client(NotebookClient):
    """nbclient, also keeping the outputs nbval keeps of the cells in ``watch``."""

    def __init__(self, nb, watch, **kw):
        super().__init__(nb, **kw)
        self.watch, self.messages = watch, {i: [] for i in watch}

    def process_message(self, msg, cell, cell_index):
        if cell_index in self.watch and (out := nbval_output(msg)) is not None:
            self.messages[cell_index].append(out)
        return super().process_message(msg, cell, cell_index)

    def silently(self, code: str, **expressions) -> dict:
        """Run ``code`` in the kernel without a trace in the notebook; the values of ``expressions``."""
        reply = self.wait_for_reply(
            self.kc.execute(code, silent=True, store_history=False, user_expressions=expressions)
        )
        assert reply["content"]["status"] == "ok", reply["content"]
        return {k: ast.literal_eval(v["data"]["text/plain"]) for k, v in reply["content"]["user_expressions"].items()}


def _failure(cell, err: BaseException) -> str:
    """The cell by its id, and the error with its traceback (without the terminal's colours)."""
    return f"cell {cell.get('id', '?')}: {_plain(err)}"


def _plain(err: BaseException) -> str:
    return re.sub(r"\x1b\[[0-9;]*m", "", f"{type(err).__name__}: {err}")


def run_chapter(notebook: Path, workdir: Path, cell_timeout_s: float = CELL_TIMEOUT_S) -> ChapterRun:
    """Run one chapter in quick mode, then the student edition's replayed cells.

    Parameters
    ----------
    notebook : pathlib.Path
        ``notebooks/NN_name.ipynb``.
    workdir : pathlib.Path
        A new folder: the prepared and executed notebooks and ``figures/`` go there.
    cell_timeout_s : float
        Each cell's time limit (s); one that runs longer fails, named by its source.

    Returns
    -------
    ChapterRun
        A failing cell is recorded in ``error``, not raised.
    """
    import papermill

    from lab.course.edition import edition_text

    workdir.mkdir(parents=True, exist_ok=True)
    figures, prepared_path = workdir / "figures", workdir / f"prepared-{notebook.name}"
    papermill.execute_notebook(
        str(notebook),
        str(prepared_path),
        prepare_only=True,
        parameters={"quick": True, "figures_dir": str(figures)},
        progress_bar=False,
    )
    prepared = nbformat.read(prepared_path, as_version=4)
    nb = nbformat.read(prepared_path, as_version=4)
    edition, n_stubs = edition_text(notebook, up="../")
    plan = replay_plan(notebook, edition, STUDENT_DIR) if n_stubs else Plan(None, "no exercises")
    run = ChapterRun(
        notebook.name, nb, prepared, plan=plan, edition_sha256=hashlib.sha256(edition.encode()).hexdigest()
    )
    watch = {i for i, c in enumerate(nb.cells) if c.cell_type == "code" and nbval_options(c)["check"]}
    client = _Client(
        nb,
        watch,
        timeout=cell_timeout_s,
        startup_timeout=60,
        kernel_name="lab-test-this-python",
        kernel_manager_class=_Manager,
        raise_on_iopub_timeout=True,
        resources={"metadata": {"path": str(NOTEBOOKS_DIR)}},
    )
    try:
        with client.setup_kernel():
            client.reset_execution_trackers()
            client.silently(_AUDIT)
            for i, cell in enumerate(nb.cells):
                try:
                    client.execute_cell(cell, i)
                except Exception as err:  # noqa: BLE001 - recorded: each check says what it means for it
                    run.error = _failure(cell, err)
                    break
                run.ran = i + 1
            run.figures = sorted(str(p.relative_to(figures)) for p in figures.rglob("*") if p.is_file())
            count = {c.get("execution_count"): c.get("id") for c in nb.cells[: run.ran] if c.cell_type == "code"}
            run.relative = [(count.get(n, n), e, p) for n, e, p in json.loads(client.silently("", p=_AUDITED)["p"])]
            if not run.error and plan.cells:
                _replay(client, nb, plan, run)
    except BaseException as err:  # a dead kernel, pytest-timeout: the chapter's other checks need not wait again
        run.error = run.error or f"the run stopped: {_plain(err)}"
        if isinstance(err, (KeyboardInterrupt, SystemExit)):
            raise
    finally:
        run.checked = client.messages
        nbformat.write(nb, workdir / notebook.name)
    return run


def _replay(client: _Client, nb, plan: Plan, run: ChapterRun) -> None:
    """Run the plan's cells (their student-edition source) after the chapter, in order,
    stopping at the first that fails; their outputs go to ``run.replay``, not into ``nb``."""
    start = len(nb.cells)
    try:
        for r in plan.cells:
            cell = nbformat.v4.new_code_cell(r.source, metadata={"tags": [r.kind], "student_replay_of": r.index})
            nb.cells.append(cell)
            entry = {"index": r.index, "kind": r.kind, "text": "", "error": ""}
            run.replay.append(entry)
            try:
                client.execute_cell(cell, len(nb.cells) - 1)
            except BaseException as err:  # the student edition's failure (pytest-timeout too), not the chapter's
                entry["error"] = _plain(err)
                if isinstance(err, (KeyboardInterrupt, SystemExit)):
                    raise
            finally:
                entry["text"] = output_text(nb.cells[-1])
            if entry["error"]:
                break
    finally:
        del nb.cells[start:]


class ChapterRuns:
    """Each chapter's :class:`ChapterRun`, made on first use in this process.

    Parameters
    ----------
    root : pathlib.Path
        A temporary folder for this session; one sub-folder per chapter.
    """

    def __init__(self, root: Path):
        self.root, self.runs = root, {}

    def get(self, notebook: Path, request) -> ChapterRun:
        """The run of ``notebook``, for the test of ``request`` (one of :data:`SHARED_CHECKS`).

        Parameters
        ----------
        notebook : pathlib.Path
            The chapter.
        request : pytest.FixtureRequest
            The asking test's.

        Returns
        -------
        ChapterRun
        """
        assert request.node.originalname in SHARED_CHECKS, (
            f"{request.node.originalname} reads a chapter's shared run: add it to chapter_run.SHARED_CHECKS, "
            "so that xdist runs it beside the chapter's other checks"
        )
        if notebook.name not in self.runs:
            print(f"running {notebook.name} (quick) for its checks", file=sys.stderr)
            self.runs[notebook.name] = run_chapter(notebook, self.root / notebook.stem)
        return self.runs[notebook.name]
