"""A partial ``scripts/reproduce`` (some chapters) changes no tracked file it did not re-make:
its times go to build/chapter_times.partial.csv beside the full run's, the README's and
docs/course.md's time tables stay, a recorded copy keeps its cell ids, and a result table
whose results are the committed ones keeps its committed file even where its ``wall_s``
moved; the tables it re-made are compared with the committed ones ("nothing moved").

Checked with a stand-in papermill (no notebook runs): the venv's python is a script that,
for ``-m papermill``, writes the executed chapter as papermill does (the source's cells, an
injected-parameters cell with a new random id, the run's start time), the matplotlib backend
its kernel would draw with (beside it, ``NN_name.backend``) and a ten-split table
into the chapter's figures_dir with a new ``wall_s`` column, the results as ``LAB_FAKE_RESULT``
says.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from lab.course.times import times_markdown

ROOT = Path(__file__).resolve().parent.parent
TABLE = "table_model_ten_splits.csv"
COMMITTED_TABLE = (
    "split,seed,test_mse_m2,test_mean_distance_m,wall_s\n0,11,2.0e-08,0.000177,0.676\n1,12,1.0e-07,0.000466,0.843\n"
)

FAKE_PAPERMILL = r"""
import json, os, secrets, sys, time
from pathlib import Path

src, out = Path(sys.argv[1]), Path(sys.argv[2])
args = sys.argv[3:]
cwd = Path(args[args.index("--cwd") + 1])
params = {args[k + 1]: args[k + 2] for k, a in enumerate(args) if a == "-p"}
nb = json.loads(src.read_text())
inject = {"cell_type": "code", "id": secrets.token_hex(4), "metadata": {"tags": ["injected-parameters"]},
          "execution_count": 1, "outputs": [], "source": f"figures_dir = {params['figures_dir']!r}\n"}
nb["cells"].insert(1, inject)
stamp = time.strftime("%Y-%m-%dT%H:%M:%S")
nb["metadata"]["papermill"] = {"parameters": params, "start_time": stamp, "duration": 0.1}
out.write_text(json.dumps(nb, indent=1))
out.with_suffix(".backend").write_text(os.environ.get("MPLBACKEND", ""))  # the kernel's matplotlib backend
figures = (cwd / params["figures_dir"]).resolve()
figures.mkdir(parents=True, exist_ok=True)
if src.name.startswith("01_"):
    moved = os.environ.get("LAB_FAKE_RESULT") == "moved"
    rows = ["split,seed,test_mse_m2,test_mean_distance_m,wall_s",
            f"0,11,2.0e-08,{'0.000300' if moved else '0.000177'},{time.perf_counter():.6f}",
            f"1,12,1.0e-07,0.000466,{time.perf_counter():.6f}"]
    (figures / "table_model_ten_splits.csv").write_text("\n".join(rows) + "\n")
"""

FAKE_PYTHON = """#!/usr/bin/env bash
if [ "$1 $2" = "-m papermill" ]; then
    shift 2
    exec {real} {fake} "$@"
fi
exec {real} "$@"
"""


def _chapter(name: str) -> dict:
    cells = [
        {"cell_type": "markdown", "id": f"{name[:2]}-title", "metadata": {}, "source": f"# Chapter {name[:2]}"},
        {
            "cell_type": "code",
            "id": f"{name[:2]}-parameters",
            "metadata": {"tags": ["parameters"]},
            "execution_count": None,
            "outputs": [],
            "source": 'figures_dir = "../build/figures"\n',
        },
        {
            "cell_type": "code",
            "id": f"{name[:2]}-work",
            "metadata": {},
            "execution_count": None,
            "outputs": [],
            "source": "print(1)\n",
        },  # fmt: skip
    ]
    return {"cells": cells, "metadata": {}, "nbformat": 4, "nbformat_minor": 5}


@pytest.fixture
def repo(tmp_path):
    """A repository of two chapters with everything a full run has committed."""
    root = tmp_path / "repo"
    for folder in ("scripts", "notebooks", "figures/notebooks", "docs", "build"):
        (root / folder).mkdir(parents=True)
    for script in ("reproduce", "_env.sh", "compare_tables.py", "record_notebooks.py"):
        (root / "scripts" / script).write_bytes((ROOT / "scripts" / script).read_bytes())
    (root / "scripts" / "reproduce").chmod(0o755)
    (root / "environment.txt").write_text("numpy\n")
    (root / "pyproject.toml").write_text("[project]\nname = 'x'\n")
    venv = root / ".venv"
    (venv / "bin").mkdir(parents=True)
    (tmp_path / "fake_papermill.py").write_text(FAKE_PAPERMILL)
    (venv / "bin" / "python").write_text(FAKE_PYTHON.format(real=sys.executable, fake=tmp_path / "fake_papermill.py"))
    (venv / "bin" / "python").chmod(0o755)
    sha = [f"$(_lab_sha256 {root}/{f})" for f in ("environment.txt", "pyproject.toml")]
    script = f"source {root}/scripts/_env.sh >/dev/null 2>&1; echo {sha[0]}-{sha[1]}"
    stamp = subprocess.run(["bash", "-c", script], capture_output=True, text=True).stdout.strip()
    (venv / ".environment.sha256").write_text(stamp + "\n")
    for name in ("01_a.ipynb", "02_b.ipynb"):
        (root / "notebooks" / name).write_text(json.dumps(_chapter(name), indent=1) + "\n")
    for page in ("README.md", "docs/course.md"):
        (root / page).write_text("# Page\n\n<!-- chapter-times -->\n<!-- /chapter-times -->\n\nEnd.\n")
    (root / "figures" / TABLE).write_text(COMMITTED_TABLE)
    # a full run stores the recorded copies (their injected cells get random ids, today's date)
    run = _run(root, "01", "02")
    assert run.returncode == 0, run.stderr
    # the times and the table as committed by a full run on another machine
    (root / "figures" / "chapter_times.csv").write_text(
        "chapter,quick_s,full_s,full_date,full_machine,full_load,full_jobs\n"
        '01_a.ipynb,,30.0,2026-01-01,"2 CPUs, Model A",1.0,2\n02_b.ipynb,,95.0,2026-01-01,"2 CPUs, Model A",1.0,2\n'
    )
    block = times_markdown(root / "notebooks", root / "figures" / "chapter_times.csv")
    for page in ("README.md", "docs/course.md"):
        (root / page).write_text(f"# Page\n\n<!-- chapter-times -->\n{block}<!-- /chapter-times -->\n\nEnd.\n")
    return root


def _run(root: Path, *args, result: str = "same"):
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "LAB_ROOT")}
    env |= {"LAB_REPRODUCE_JOBS": "1", "PYTHONPATH": str(ROOT), "LAB_FAKE_RESULT": result}
    return subprocess.run(["bash", str(root / "scripts" / "reproduce"), *args], capture_output=True, text=True,
                          timeout=180, env=env)  # fmt: skip


TRACKED = ("README.md", "docs/course.md", "figures/chapter_times.csv", f"figures/{TABLE}",
           "figures/notebooks/01_a.ipynb", "figures/notebooks/02_b.ipynb", "notebooks/01_a.ipynb")  # fmt: skip


def test_a_partial_run_changes_no_tracked_file_when_nothing_moved(repo):
    before = {p: (repo / p).read_bytes() for p in TRACKED}
    r = _run(repo, "01")
    assert r.returncode == 0, r.stderr
    after = {p: (repo / p).read_bytes() for p in TRACKED}
    assert [p for p in TRACKED if before[p] != after[p]] == []
    # its time is kept beside the full run's, and said so
    with (repo / "build" / "chapter_times.partial.csv").open(newline="") as fh:
        rows = {r["chapter"]: r for r in csv.DictReader(fh)}
    assert list(rows) == ["01_a.ipynb"] and rows["01_a.ipynb"]["full_s"]
    assert "the last full run's, figures/chapter_times.csv: 30.0 s" in r.stderr
    assert "a partial run (1 of 2 chapters)" in r.stderr
    # the re-made table was compared ("nothing moved") and kept as committed despite its new wall_s
    assert "nothing moved" in r.stdout and f"kept: figures/{TABLE} as committed" in r.stdout
    assert "figures/notebooks/01_a.ipynb unchanged" in r.stderr
    # a chapter that re-makes no table says so
    r = _run(repo, "02")
    assert r.returncode == 0 and "no result table was re-made" in r.stderr, r.stderr
    assert all((repo / p).read_bytes() == before[p] for p in TRACKED)


def test_a_partial_run_says_what_moved(repo):
    before = {p: (repo / p).read_bytes() for p in ("README.md", "docs/course.md", "figures/chapter_times.csv")}
    r = _run(repo, "01", result="moved")
    assert r.returncode == 1, r.stderr
    assert "moved: table_model_ten_splits.csv: split=0, test_mean_distance_m: 0.000177 -> 0.0003" in r.stdout
    assert "0.0003" in (repo / "figures" / TABLE).read_text()  # the new result stays, to be looked at
    assert all((repo / p).read_bytes() == b for p, b in before.items())


def test_a_full_run_updates_the_times_and_keeps_unmoved_tables(repo):
    readme = (repo / "README.md").read_text()
    r = _run(repo, "01-02")
    assert r.returncode == 0, r.stderr
    assert (repo / "figures" / TABLE).read_text() == COMMITTED_TABLE
    assert (repo / "README.md").read_text() != readme  # the full run's times replace 30 s and 95 s
    assert "Model A" not in (repo / "README.md").read_text()  # no footnote mixing two machines
    # the kernels draw inline, as in JupyterLab (under _env.sh's Agg, plt.show() shows nothing)
    backend = (repo / "build" / "notebooks" / "01_a.backend").read_text()
    assert backend == "module://matplotlib_inline.backend_inline"


def _script(name: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_recorded_copies_keep_the_committed_cell_ids(tmp_path):
    """papermill's injected-parameters cell gets a new random id from nbformat on every run;
    the recorded copy keeps the id the committed copy has (every other cell: the source's)."""
    record = _script("record_notebooks")
    name = "03_learned_model.ipynb"
    nb = json.loads((ROOT / "notebooks" / name).read_text())
    at = next(i for i, c in enumerate(nb["cells"]) if "parameters" in c["metadata"].get("tags", []))
    injected = {"cell_type": "code", "id": "0f1e2d3c", "metadata": {"tags": ["injected-parameters"]},
                "execution_count": 2, "outputs": [], "source": 'figures_dir = "../figures"\n'}  # fmt: skip
    nb["cells"].insert(at + 1, injected)
    nb["metadata"]["papermill"] = {"parameters": {"figures_dir": "../figures"}, "start_time": "2030-01-01T00:00:00"}
    executed = tmp_path / name
    executed.write_text(json.dumps(nb))
    committed = json.loads((ROOT / "figures" / "notebooks" / name).read_text())
    copy = record.recorded_copy(executed, ROOT / "figures", ROOT / "figures" / "notebooks", ROOT / "notebooks" / name)
    assert [c["id"] for c in copy["cells"]] == [c["id"] for c in committed["cells"]]
    # without a stored copy: the injected cell is named for what it is, the others keep the source's
    copy = record.recorded_copy(executed, ROOT / "figures", tmp_path / "site", ROOT / "notebooks" / name)
    ids = [c["id"] for c in copy["cells"]]
    assert ids[at + 2] == "injected-parameters" and len(set(ids)) == len(ids)
    assert [i for i in ids if i not in ("injected-parameters", "recorded-run")] == [
        c["id"] for c in nb["cells"] if c is not injected
    ]


def test_compare_tables_help_and_exit_codes(tmp_path):
    script = str(ROOT / "scripts" / "compare_tables.py")
    r = subprocess.run([sys.executable, script, "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    assert "usage:" in r.stdout and "--keep-committed-timings" in r.stdout and "Exit: 0 nothing moved" in r.stdout
    r = subprocess.run([sys.executable, script], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "usage:" in r.stderr
    missing = [sys.executable, script, str(tmp_path / "no"), str(tmp_path), "t.csv"]
    r = subprocess.run(missing, capture_output=True, text=True)
    assert r.returncode == 2 and "no such folder" in r.stderr and "Traceback" not in r.stderr
    (tmp_path / "t.csv").write_bytes(b"\xff\xfe\x00garbage")
    r = subprocess.run([sys.executable, script, str(tmp_path), str(tmp_path), "t.csv"], capture_output=True, text=True)
    assert r.returncode == 2 and "not a readable CSV table" in r.stdout and "Traceback" not in r.stderr


def test_compare_tables_keeps_the_committed_file_when_only_timings_differ(tmp_path, capsys):
    compare = _script("compare_tables")
    ref, new = tmp_path / "ref", tmp_path / "new"
    ref.mkdir(), new.mkdir()
    (ref / TABLE).write_text(COMMITTED_TABLE)
    retimed = COMMITTED_TABLE.replace("0.676", "0.912")
    (new / TABLE).write_text(retimed)
    assert compare.main([str(ref), str(new), TABLE]) == 0  # without the flag: compared, left alone
    assert (new / TABLE).read_text() == retimed
    assert compare.main(["--keep-committed-timings", str(ref), str(new), TABLE]) == 0
    assert (new / TABLE).read_text() == COMMITTED_TABLE
    assert "kept:" in capsys.readouterr().out
    # a result within the tolerance but not the same text is the new run's: kept as it came
    close = COMMITTED_TABLE.replace("0.000177", "0.0001770000001")
    (new / TABLE).write_text(close)
    assert compare.main(["--keep-committed-timings", str(ref), str(new), TABLE]) == 0
    assert (new / TABLE).read_text() == close and "nothing moved" in capsys.readouterr().out
