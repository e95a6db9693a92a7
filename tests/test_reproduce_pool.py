"""scripts/reproduce runs chapters LAB_REPRODUCE_JOBS at a time, longest first, and stops at
the first failure with that chapter's log -- checked with a stand-in papermill (no notebook
runs): the venv's python is a script that records each chapter's start and end."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

FAKE_PYTHON = """#!/usr/bin/env bash
if [ "$1 $2" = "-m papermill" ]; then
    name="$(basename "$3")"
    echo "start $name $(date +%s.%N)" >> "{log}"
    case "$name" in *FAIL*) echo "deliberate failure in $name" >&2; exit 3 ;; esac
    sleep 1.5
    printf '{{"metadata": {{"papermill": {{"duration": 0.3, "parameters": {{}}}}}}}}' > "$4"
    echo "end $name $(date +%s.%N)" >> "{log}"
    exit 0
fi
exec {real} "$@"
"""


@pytest.fixture
def repo(tmp_path):
    root = tmp_path / "repo"
    shutil.copytree(ROOT / "scripts", root / "scripts")
    (root / "notebooks").mkdir()
    (root / "figures").mkdir()
    (root / "environment.txt").write_text("numpy\n")
    (root / "pyproject.toml").write_text("[project]\nname = 'x'\n")
    venv = root / ".venv"
    (venv / "bin").mkdir(parents=True)
    log = tmp_path / "calls.log"
    (venv / "bin" / "python").write_text(FAKE_PYTHON.format(real=sys.executable, log=log))
    (venv / "bin" / "python").chmod(0o755)
    # a built .venv: the stamp matches, so _env.sh installs nothing
    sha = [f"$(_lab_sha256 {root}/{f})" for f in ("environment.txt", "pyproject.toml")]
    script = f"source {root}/scripts/_env.sh >/dev/null 2>&1; echo {sha[0]}-{sha[1]}"
    stamp = subprocess.run(["bash", "-c", script], capture_output=True, text=True).stdout.strip()
    (venv / ".environment.sha256").write_text(stamp + "\n")
    return root, log


def _chapters(root: Path, times: dict[str, float]):
    for name in times:
        (root / "notebooks" / name).write_text(json.dumps({"cells": []}))
    rows = ["chapter,quick_s,full_s,quick_date,full_date"] + [f"{n},,{t},," for n, t in times.items()]
    (root / "figures" / "chapter_times.csv").write_text("\n".join(rows) + "\n")


def _run(root: Path, *args, jobs="2"):
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "LAB_ROOT")}
    env["LAB_REPRODUCE_JOBS"] = jobs
    return subprocess.run(["bash", str(root / "scripts" / "reproduce"), *args], capture_output=True, text=True,
                          timeout=120, env=env)  # fmt: skip


def _events(log: Path):
    return [line.split() for line in log.read_text().splitlines()]


def test_two_chapters_at_a_time_longest_first(repo):
    root, log = repo
    _chapters(root, {"01_a.ipynb": 10.0, "02_b.ipynb": 300.0, "03_c.ipynb": 50.0, "04_d.ipynb": 20.0})
    r = _run(root, "01-04")
    assert r.returncode == 0, r.stderr
    events = _events(log)
    launched = [line.split("notebooks/")[1] for line in r.stderr.splitlines() if line.startswith("==> [")]
    assert launched == ["02_b.ipynb", "03_c.ipynb", "04_d.ipynb", "01_a.ipynb"]
    running, most = 0, 0
    for what, _, _ in events:
        running += 1 if what == "start" else -1
        most = max(most, running)
    assert most == 2  # never more than LAB_REPRODUCE_JOBS at once (each sleeps 1.5 s: they overlap)
    import csv

    with (root / "figures" / "chapter_times.csv").open(newline="") as fh:
        times = {r["chapter"]: r for r in csv.DictReader(fh)}
    # each chapter's time recorded: the wall time of its whole papermill run (the stand-in
    # sleeps 1.5 s), not papermill's own record of the cells (0.3 s), with the run's conditions
    for name in ("01_a.ipynb", "02_b.ipynb", "03_c.ipynb", "04_d.ipynb"):
        assert float(times[name]["full_s"]) >= 1.5 and times[name]["quick_s"] == "", times[name]
        assert times[name]["full_jobs"] == "2" and "CPUs" in times[name]["full_machine"], times[name]


def test_a_failing_chapter_stops_the_run_and_shows_its_log(repo):
    root, log = repo
    _chapters(root, {"01_FAIL.ipynb": 100.0, "02_b.ipynb": 10.0, "03_c.ipynb": 5.0, "04_d.ipynb": 1.0})
    r = _run(root, "01-04", jobs="1")
    assert r.returncode == 1
    assert "01_FAIL.ipynb FAILED" in r.stderr and "deliberate failure in 01_FAIL.ipynb" in r.stderr
    assert [name for what, name, _ in _events(log) if what == "start"] == ["01_FAIL.ipynb"]  # nothing after it
    r = _run(root, "01-04", jobs="0")
    assert r.returncode == 2 and "LAB_REPRODUCE_JOBS" in r.stderr
