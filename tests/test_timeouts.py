"""A hang fails by name within minutes instead of running into CI's 90-minute limit.

Every test has pytest.ini's ``timeout`` (pytest-timeout); the chapters' tests declare a
longer one, and every notebook cell gets papermill's ``execution_timeout``
(:data:`helpers.CELL_TIMEOUT_S`, via :func:`helpers.execute_notebook`). Both are exercised
here on deliberate hangs with short limits.
"""

from __future__ import annotations

import configparser
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pytest
from helpers import CELL_TIMEOUT_S, NOTEBOOK_TEST_TIMEOUT_S, execute_notebook, subprocess_env

ROOT = Path(__file__).resolve().parent.parent


def test_every_test_has_a_time_limit():
    ini = configparser.ConfigParser()
    ini.read(ROOT / "pytest.ini")
    limit = float(ini["pytest"]["timeout"])
    assert 60 <= limit <= 600
    assert limit < NOTEBOOK_TEST_TIMEOUT_S <= 1800 and CELL_TIMEOUT_S < NOTEBOOK_TEST_TIMEOUT_S


def test_a_hanging_test_fails_by_name(tmp_path):
    (tmp_path / "test_hang.py").write_text("import time\n\ndef test_sleeps_forever():\n    time.sleep(600)\n")
    (tmp_path / "pytest.ini").write_text((ROOT / "pytest.ini").read_text())
    t0 = time.monotonic()
    r = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-o", "timeout=2", "test_hang.py"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        env=subprocess_env(),
    )
    assert r.returncode == 1, r.stdout + r.stderr
    assert "Timeout" in r.stdout and "test_sleeps_forever" in r.stdout, r.stdout
    assert time.monotonic() - t0 < 100


@pytest.mark.timeout(120)
def test_a_hanging_cell_fails_naming_the_cell(tmp_path):
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell("x = 1"), nbformat.v4.new_code_cell("import time\ntime.sleep(600)")]
    src = tmp_path / "hang.ipynb"
    nbformat.write(nb, src)
    t0 = time.monotonic()
    with pytest.raises(TimeoutError) as err:  # nbclient's CellTimeoutError
        execute_notebook(src, tmp_path / "out.ipynb", execution_timeout=3, kernel_name="python3")
    assert time.monotonic() - t0 < 100
    text = str(err.value)
    assert "timed out" in text and "time.sleep(600)" in text, text  # the cell, by its source
