"""ruff's lint and format checks over lab/, tests/, benchmarks/ and notebooks/ (settings in
ruff.toml). To fix what they report: ``ruff check --fix . && ruff format .``."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PATHS = ["lab", "tests", "benchmarks", "notebooks"]


def _ruff() -> list[str]:
    exe = Path(sys.executable).with_name("ruff")
    if exe.exists():
        return [str(exe)]
    if shutil.which("ruff"):
        return ["ruff"]
    pytest.fail("ruff is not installed (it is pinned in environment.txt)")


@pytest.mark.parametrize("check", [["check"], ["format", "--check"]], ids=["lint", "format"])
def test_ruff(check):
    r = subprocess.run([*_ruff(), *check, "--no-cache", *PATHS], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, f"ruff {' '.join(check)} found problems:\n{r.stdout}{r.stderr}"
