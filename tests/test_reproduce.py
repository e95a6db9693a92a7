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


def test_quick_runs_write_build_figures_and_full_runs_figures():
    # a quick run must never replace the shipped Table I rows with coarse "quick run" rows
    for spelling in ("True", "true", "1"):
        code, _, err = _dry("04", "--", "-p", "quick", spelling)
        assert code == 0 and "figures_dir: ../build/figures" in err, err
    code, _, err = _dry("04")
    assert code == 0 and "figures_dir: ../figures" in err, err
    code, _, err = _dry("04", "--", "-p", "quick", "False")
    assert code == 0 and "figures_dir: ../figures" in err, err


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=[nb.name for nb in NOTEBOOKS])
def test_hand_runs_write_build_figures(notebook):
    params = papermill.inspect_notebook(str(notebook))
    assert params["figures_dir"]["default"].strip("'\"") == "../build/figures"
    assert "n_jobs" in params or "jobs" not in params  # one name for worker counts


def _compare():
    import importlib.util

    spec = importlib.util.spec_from_file_location("compare_tables", ROOT / "scripts" / "compare_tables.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_compare_tables_reports_moved_cells(tmp_path, capsys):
    compare = _compare()
    ref, new = tmp_path / "ref", tmp_path / "new"
    ref.mkdir(), new.mkdir()
    head = "condition,circle_cm,square_cm,wall_s\n"
    (ref / "t.csv").write_text(head + "Sim,0.50,0.40,1.0\nSoft IK,1.7e-07,2.1e-07,9.0\n")
    (new / "t.csv").write_text(head + "Sim,0.5000001,0.40,55.0\nSoft IK,1.9e-07,2.0e-07,3.0\n")
    assert compare.main([str(ref), str(new), "t.csv"]) == 0  # round-off, timings and near-zero noise
    (new / "t.csv").write_text(head + "Sim,0.51,0.40,1.0\nSoft IK,1.7e-07,2.1e-07,9.0\n")
    assert compare.main([str(ref), str(new), "t.csv"]) == 1
    out = capsys.readouterr().out
    assert "condition=Sim, circle_cm: 0.5 -> 0.51" in out and "square_cm" not in out.split("moved:")[-1]
    (new / "t.csv").unlink()
    assert compare.main([str(ref), str(new), "t.csv"]) == 1 and "missing" in capsys.readouterr().out


def test_full_reproduce_compares_with_the_committed_tables():
    text = (ROOT / "scripts" / "reproduce").read_text()
    assert "compare_tables.py" in text and "table1.csv" in text and "table_model_ten_splits.csv" in text
