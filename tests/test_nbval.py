"""nbval checks the headline numbers each chapter prints (cells tagged ``nbval-check-output``).

Each chapter with such cells is prepared in quick mode by papermill (parameters injected,
stored outputs kept) and run once (``tests/chapter_run.py``, the run its other checks read
too); what the kernel sent for every tagged cell is compared with the output stored in the
committed notebook (``scripts/pin-outputs`` stores them), after the substitutions of
``notebooks/nbval-sanitize.cfg``, by nbval's own comparison (``tests/nbval_outputs.py``).
As under ``pytest --nbval-lax``, a cell that raises fails too. A change that moves a
headline number fails here, naming the notebook and the cell. A chapter with a cell nbval
would skip or let raise is run by nbval itself instead, into ``.nbval/`` beside
``notebooks/`` (so its relative paths still resolve).
"""

import json
import subprocess
import sys
from pathlib import Path

import nbformat
import papermill
import pytest
from helpers import CELL_TIMEOUT_S, NOTEBOOK_TEST_TIMEOUT_S
from nbval_outputs import compare, nbval_options, shares_run

ROOT = Path(__file__).resolve().parent.parent
TAG = "nbval-check-output"
SANITIZE = ROOT / "notebooks" / "nbval-sanitize.cfg"
NOTEBOOKS = [
    nb
    for nb in sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    if any(TAG in c.get("metadata", {}).get("tags", []) for c in json.loads(nb.read_text())["cells"])
]


def test_only_checked_cells_keep_outputs():
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        for c in json.loads(nb.read_text())["cells"]:
            if c["cell_type"] == "code" and c.get("outputs"):
                assert TAG in c.get("metadata", {}).get("tags", []), f"{nb.name} [{c.get('id')}] keeps outputs"
            if TAG in c.get("metadata", {}).get("tags", []):
                assert c.get("outputs") and c.get("execution_count"), (
                    f"{nb.name} [{c.get('id')}]: run scripts/pin-outputs"
                )


@pytest.mark.slow
@pytest.mark.timeout(NOTEBOOK_TEST_TIMEOUT_S)
@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[nb.name for nb in NOTEBOOKS])
def test_headline_numbers(notebook, chapter_runs, request, tmp_path):
    if not shares_run(nbformat.read(notebook, as_version=4)):
        return run_nbval(notebook, tmp_path)
    run = chapter_runs.get(notebook, request)
    problems = [f"the notebook failed: {run.error}"] if run.error else []
    sanitize = SANITIZE.read_text()
    code_cells = [(i, c) for i, c in enumerate(run.prepared.cells) if c.cell_type == "code"]
    for n, (i, cell) in enumerate(code_cells):  # nbval's "Cell n" counts the code cells
        check = nbval_options(cell)["check"] and i < run.ran
        why = compare(cell, run.checked.get(i, []), check, sanitize, request.config)
        if why:
            problems.append(f"Cell {n} [{cell.get('id')}]: {why}")
    assert not problems, f"nbval: a headline number of {notebook.name} moved (or the notebook failed):\n" + "\n\n".join(
        problems
    )


def run_nbval(notebook: Path, tmp_path: Path) -> None:
    """nbval's own run of ``notebook`` (``pytest --nbval-lax``), for a chapter whose cells
    nbval would not all execute as the shared run does."""
    prepared = ROOT / ".nbval" / notebook.name
    prepared.parent.mkdir(exist_ok=True)
    papermill.execute_notebook(
        str(notebook),
        str(prepared),
        prepare_only=True,
        parameters={"quick": True, "figures_dir": str(tmp_path / "figures")},
    )
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "-p",
            "no:xdist",
            "--nbval-lax",
            f"--nbval-cell-timeout={CELL_TIMEOUT_S}",
            "-o",
            f"timeout={NOTEBOOK_TEST_TIMEOUT_S}",
            "--nbval-current-env",
            f"--nbval-sanitize-with={SANITIZE}",
            str(prepared),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=NOTEBOOK_TEST_TIMEOUT_S - 60,
    )
    assert r.returncode == 0, (
        f"nbval: a headline number of {notebook.name} moved (or the notebook failed):\n{r.stdout[-6000:]}"
    )


def test_the_comparison_is_nbvals(request):
    """Streams merged and volatile text sanitized before comparing; a moved number, an extra
    output, a stored output never run each fail; an unchecked cell is not compared."""
    sanitize = SANITIZE.read_text()
    stored = nbformat.v4.new_output("stream", name="stdout", text="error 0.45 cm in 12.3 s\n")
    ref = nbformat.v4.new_code_cell("print(x)", execution_count=1, outputs=[stored])
    same = [{"output_type": "stream", "name": "stdout", "text": t} for t in ("error 0.45 cm ", "in 99.1 s\n")]
    assert compare(ref, same, True, sanitize, request.config) == ""
    moved = [{"output_type": "stream", "name": "stdout", "text": "error 0.46 cm in 1 s\n"}]
    why = compare(ref, moved, True, sanitize, request.config)
    assert "Cell outputs differ" in why and "0.45" in why and "0.46" in why, why
    assert compare(ref, moved, False, sanitize, request.config) == ""
    extra = same + [{"output_type": "stream", "name": "stderr", "text": "warning\n"}]
    assert "Unexpected output fields" in compare(ref, extra, True, sanitize, request.config)
    unrun = nbformat.v4.new_code_cell("print(x)", outputs=[stored])
    assert compare(unrun, same, False, sanitize, request.config) == "Unrun reference cell has outputs"


def test_nbval_options_as_nbval_reads_them():
    tagged = nbformat.v4.new_code_cell("x", metadata={"tags": [TAG]})
    commented = nbformat.v4.new_code_cell("# NBVAL_CHECK_OUTPUT\nx")
    plain = nbformat.v4.new_code_cell("x")
    assert nbval_options(tagged)["check"] and nbval_options(commented)["check"] and not nbval_options(plain)["check"]
    skipped = nbformat.v4.new_code_cell("x", metadata={"tags": ["nbval-skip"]})
    raising = nbformat.v4.new_code_cell("x", metadata={"tags": ["raises-exception"]})
    assert shares_run(nbformat.v4.new_notebook(cells=[tagged, commented, plain]))
    assert not shares_run(nbformat.v4.new_notebook(cells=[tagged, skipped]))  # nbval runs those itself
    assert not shares_run(nbformat.v4.new_notebook(cells=[raising]))
