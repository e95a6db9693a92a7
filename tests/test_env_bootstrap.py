"""The scripts' first-build path (scripts/_env.sh creating .venv) keeps stderr.

Each script is run in a copy of the repository's scripts/ with a stand-in interpreter:
``LAB_PYTHON`` "creates" the virtual environment by writing a fake ``.venv/bin/python``
that answers pip and ipykernel with success, JupyterLab with a URL and the arguments it
was given, and everything else with a deliberate error on stderr (``python -m lab.course``
too, unless a test asks for the real one: the student command's build of its edition).
A build that silenced the shell's stderr (as ``exec 9<&- 2>/dev/null`` did) loses that
error and the build's own progress lines; this test sees both, on the first run and on the
second (when .venv is up to date and the build is skipped). The student command's first
run prints JupyterLab's URL with its token and opens build/student/. scripts/test's
pytest command line shows how many workers it starts.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

FAKE_VENV_PYTHON = """#!/usr/bin/env bash
# stand-in for .venv/bin/python
case "$1 $2" in
    "-c "*) exec {real} "$@" ;;
    "-m pip" | "-m ipykernel") exit 0 ;;
    "-m jupyterlab")
        echo "    http://127.0.0.1:8888/lab?token=deliberate-token" >&2
        echo "jupyterlab args: $*" >&2
        exit 0 ;;
    "-m lab.course") [ -n "${{LAB_TEST_REAL_COURSE:-}}" ] && exec {real} "$@" ;;
esac
echo "deliberate error from python $*" >&2
exit 3
"""

FAKE_BASE_PYTHON = """#!/usr/bin/env bash
# stand-in for LAB_PYTHON: `-m venv --clear DIR` writes the fake venv interpreter
if [ "$1 $2" = "-m venv" ]; then
    dir="${{@: -1}}"
    mkdir -p "$dir/bin"
    cp "{fake_venv}" "$dir/bin/python"
    chmod +x "$dir/bin/python"
    exit 0
fi
exec {real} "$@"
"""


@pytest.fixture
def repo(tmp_path):
    root = tmp_path / "repo"
    shutil.copytree(ROOT / "scripts", root / "scripts")
    (root / "notebooks").mkdir()
    (root / "notebooks" / "01_x.ipynb").write_text("{}")
    (root / "environment.txt").write_text("numpy\n")
    (root / "pyproject.toml").write_text("[project]\nname = 'x'\n")
    fake_venv = tmp_path / "fake_venv_python"
    fake_venv.write_text(FAKE_VENV_PYTHON.format(real=sys.executable))
    fake_base = tmp_path / "fake_python"
    fake_base.write_text(FAKE_BASE_PYTHON.format(real=sys.executable, fake_venv=fake_venv))
    for f in (fake_venv, fake_base):
        f.chmod(0o755)
    return root, fake_base


def _env(fake_base: Path, **extra_env: str) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "LAB_ROOT")}
    return {**env, "LAB_PYTHON": str(fake_base), **extra_env}


def _run(root: Path, fake_base: Path, script: str, *args: str, **extra_env: str):
    return subprocess.run(
        ["bash", str(root / "scripts" / script), *args],
        capture_output=True,
        text=True,
        timeout=100,
        env=_env(fake_base, **extra_env),
    )


@pytest.mark.parametrize("script", ["test", "reproduce", "student-edition"])
def test_first_build_keeps_stderr(repo, script):
    root, fake_base = repo
    for attempt in ("first build", "built"):
        r = _run(root, fake_base, script)
        assert r.returncode != 0, (attempt, r.stderr)
        assert "deliberate error from python" in r.stderr, (attempt, r.stderr)
        if attempt == "first build":
            assert "lab: .venv is ready" in r.stderr, r.stderr
        else:
            assert "lab: installing" not in r.stderr, r.stderr


def test_first_build_of_jupyter_prints_its_url(repo):
    root, fake_base = repo
    r = _run(root, fake_base, "jupyter", "--no-browser")
    assert r.returncode == 0, r.stderr
    assert "lab: .venv is ready" in r.stderr and "token=deliberate-token" in r.stderr, r.stderr


def test_first_build_of_the_student_command_prints_its_url_and_opens_the_edition(repo):
    """A fresh clone's student command: .venv is built, the student edition is written into
    build/student/ (solutions stubbed), JupyterLab's URL with its token is printed and the
    server's root is build/student/."""
    root, fake_base = repo
    solution = {"cell_type": "code", "metadata": {"tags": ["solution"]}, "outputs": [], "execution_count": 1,
                "source": ["def f(x):\n", "    return x * 2 + 1\n"]}  # fmt: skip
    (root / "notebooks" / "01_x.ipynb").write_text(json.dumps({"cells": [solution], "metadata": {}}))
    r = _run(root, fake_base, "jupyter", "--student", "--no-browser", LAB_TEST_REAL_COURSE="1")
    assert r.returncode == 0, r.stderr
    assert "lab: .venv is ready" in r.stderr and "token=deliberate-token" in r.stderr, r.stderr
    args = next(line for line in r.stderr.splitlines() if line.startswith("jupyterlab args:")).split()
    assert f"--notebook-dir={root}/build/student" in args and "--no-browser" in args and "--student" not in args
    edition = json.loads((root / "build" / "student" / "01_x.ipynb").read_text())
    assert "NotImplementedError" in "".join(edition["cells"][0]["source"]), edition
    assert "student edition in build/student/" in r.stderr, r.stderr
    # the instructors' command stays on notebooks/
    r = _run(root, fake_base, "jupyter", "--no-browser")
    assert r.returncode == 0 and f"--notebook-dir={root}/notebooks" in r.stderr, r.stderr


def test_the_suite_runs_one_worker_per_core_and_one_more(repo):
    """scripts/test's default workers: the cores this process may use, plus one, whatever
    OMP_NUM_THREADS says (scripts/_env.sh sets it to 1, and GNU nproc would answer that);
    LAB_TEST_WORKERS overrides, and --pdb runs in one process."""
    root, fake_base = repo
    cores = len(os.sched_getaffinity(0))
    r = _run(root, fake_base, "test", OMP_NUM_THREADS="1")
    assert f"python -m pytest -n {cores + 1} --dist loadfile" in r.stderr, r.stderr
    r = _run(root, fake_base, "test", "-k", "x", LAB_TEST_WORKERS="5")
    assert "python -m pytest -n 5 --dist loadfile -k x" in r.stderr, r.stderr
    r = _run(root, fake_base, "test", "--pdb")
    assert "python -m pytest --pdb" in r.stderr and " -n " not in r.stderr, r.stderr


def test_the_scripts_keep_pythons_bytecode_cache(repo):
    """With PYTHONDONTWRITEBYTECODE set (some images set it), every process the scripts start
    would compile lab's modules again: scripts/_env.sh lets Python keep its cache."""
    root, fake_base = repo
    script = f'source "{root}/scripts/_env.sh" && echo "bytecode: ${{PYTHONDONTWRITEBYTECODE-kept}}"'
    env = _env(fake_base, PYTHONDONTWRITEBYTECODE="1")
    r = subprocess.run(["bash", "-c", script], capture_output=True, text=True, timeout=100, env=env)
    assert r.returncode == 0 and "bytecode: kept" in r.stdout, (r.stdout, r.stderr)
