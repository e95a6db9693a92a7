"""scripts/reproduce selects chapters by number or range, and notebooks run by hand never
write figures/ (their figures_dir default is build/figures; only scripts/reproduce passes
../figures)."""

import os
import subprocess
from pathlib import Path

import papermill
import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))


def _dry(*args):
    env = {**os.environ, "LAB_REPRODUCE_DRY_RUN": "1"}
    r = subprocess.run(
        [str(ROOT / "scripts" / "reproduce"), *args], capture_output=True, text=True, env=env, timeout=300
    )
    return r.returncode, r.stdout.splitlines(), r.stderr


def test_chapters_and_ranges():
    code, out, _ = _dry("01-03", "06", "--", "-p", "quick", "True")
    assert code == 0
    assert [Path(p).name[:2] for p in out[:-1]] == ["01", "02", "03", "06"]
    assert out[-1] == "papermill args: -p quick True"
    code, out, _ = _dry("-p", "quick", "True")
    assert code == 0 and len(out) - 1 == len(NOTEBOOKS) and out[-1] == "papermill args: -p quick True"
    code, _, err = _dry("99")
    assert code == 2 and "no chapter matches" in err


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[nb.name for nb in NOTEBOOKS])
def test_hand_runs_write_build_figures(notebook):
    params = papermill.inspect_notebook(str(notebook))
    assert params["figures_dir"]["default"].strip("'\"") == "../build/figures"
    assert "n_jobs" in params or "jobs" not in params  # one name for worker counts
