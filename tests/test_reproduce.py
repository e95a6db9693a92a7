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


def test_compare_tables_matches_rows_by_a_unique_key(tmp_path, capsys):
    """Rows whose first column repeats (every row 'hidden' = '20-20') are matched by the
    declared key, so a re-run that changed only timings moves nothing; a wrong value in one
    of those rows is still found, and a key that is not unique is a comparison error."""
    compare = _compare()
    ref, new = tmp_path / "ref", tmp_path / "new"
    ref.mkdir(), new.mkdir()
    committed = ROOT / "figures" / "table_model_ten_splits_real.csv"
    text = committed.read_text()
    (ref / committed.name).write_text(text)
    rows = text.splitlines()
    head = rows[0].split(",")
    wall = head.index("wall_s")
    retimed = [rows[0]] + [",".join(c if j != wall else "99.0" for j, c in enumerate(r.split(","))) for r in rows[1:]]
    (new / committed.name).write_text("\n".join(retimed) + "\n")
    assert len({r.split(",")[0] for r in rows[1:]}) == 1  # the first column alone is no key
    assert compare.main([str(ref), str(new), committed.name]) == 0
    assert "nothing moved" in capsys.readouterr().out
    test_col = head.index("test_mean_distance_m")
    bad = [r.split(",") for r in retimed]
    bad[3][test_col] = str(float(bad[3][test_col]) * 1.5)
    (new / committed.name).write_text("\n".join(",".join(r) for r in bad) + "\n")
    assert compare.main([str(ref), str(new), committed.name]) == 1
    out = capsys.readouterr().out
    assert "split=2, test_mean_distance_m" in out and "1 cell(s) moved" in out
    # an undeclared table keys on its non-numeric and index columns; duplicates are an error
    (ref / "u.csv").write_text("hidden,seed,err\n20-20,1,0.5\n20-20,2,0.6\n")
    (new / "u.csv").write_text("hidden,seed,err\n20-20,2,0.6\n20-20,1,0.5\n")
    assert compare.main([str(ref), str(new), "u.csv"]) == 0
    (ref / "u.csv").write_text("hidden,err\n20-20,0.5\n20-20,0.6\n")
    assert compare.main([str(ref), str(ref), "u.csv"]) == 2
    assert "not unique" in capsys.readouterr().out


def test_compare_tables_compares_every_committed_table_with_itself():
    compare = _compare()
    names = [p.name for p in (ROOT / "figures").glob("*.csv") if p.name in compare.KEYS]
    assert len(names) == len(compare.KEYS)
    assert compare.main([str(ROOT / "figures"), str(ROOT / "figures"), *names]) == 0
