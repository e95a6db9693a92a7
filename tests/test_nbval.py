"""nbval checks the headline numbers each chapter prints (cells tagged ``nbval-check-output``).

Each chapter with such cells is prepared in quick mode by papermill (parameters injected,
stored outputs kept) into ``.nbval/`` beside ``notebooks/`` (so its relative paths still
resolve) and run by nbval, which compares every tagged cell's output with the one stored
in the committed notebook (``scripts/pin-outputs`` stores them), after the substitutions of
``notebooks/nbval-sanitize.cfg``. A change that moves a headline number fails here, naming
the notebook and the cell.
"""

import json
import subprocess
import sys
from pathlib import Path

import papermill
import pytest
from helpers import CELL_TIMEOUT_S, NOTEBOOK_TEST_TIMEOUT_S

ROOT = Path(__file__).resolve().parent.parent
TAG = "nbval-check-output"
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
def test_headline_numbers(notebook, tmp_path):
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
            f"--nbval-sanitize-with={ROOT / 'notebooks' / 'nbval-sanitize.cfg'}",
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
