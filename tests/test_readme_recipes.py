"""The README's recipes work as written in a fresh shell.

A fresh shell has no ``.venv`` on its PATH, so a recipe line ``python -m lab ...`` finds the
system Python (no ``lab``, no ``filelock``). The recipes use ``scripts/lab`` and
``scripts/python``, which set up ``.venv`` on first use (scripts/_env.sh). Checked here: no
recipe line calls a bare ``python`` or ``.venv/bin/python``; every script a recipe names
exists and is executable; one recipe line (the ASL trunk's ``import-data``, which needs only
shipped files) runs in ``env -i`` with its ``build/`` outputs redirected to a temporary
folder; ``scripts/lab`` keeps the caller's directory for relative paths.
"""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _recipe_lines() -> list[str]:
    """The command lines of the README's fenced code blocks (continuations joined)."""
    lines, block, buf = [], False, ""
    for raw in (ROOT / "README.md").read_text().splitlines():
        if raw.startswith("```"):
            block = not block
            continue
        if not block or not raw.strip():
            continue
        buf += raw.rstrip("\\").strip() + " "
        if not raw.rstrip().endswith("\\"):
            lines.append(buf.strip())
            buf = ""
    return lines


def _fresh_shell(command: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {"HOME": str(cwd), "PATH": "/usr/local/bin:/usr/bin:/bin", "LANG": "C.UTF-8"}
    return subprocess.run(["bash", "-c", command], cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


def test_no_recipe_needs_an_activated_venv():
    lines = _recipe_lines()
    assert any(line.startswith("scripts/lab ") for line in lines)
    for line in lines:
        for part in re.split(r"&&|;|\|", line):
            words = part.split()
            if not words:
                continue
            prog = words[0]
            assert prog not in ("python", "python3", "lab"), f"README recipe needs an activated .venv: {line}"
            assert ".venv/" not in prog, f"README recipe calls into .venv directly: {line}"
            if "scripts/" in prog:
                script = (ROOT / "notebooks" / prog).resolve() if prog.startswith("../") else ROOT / prog
                assert script.is_file() and os.access(script, os.X_OK), f"README names {prog}, not an executable"


def test_a_recipe_line_runs_as_written_in_a_fresh_shell(tmp_path):
    (line,) = [x for x in _recipe_lines() if x.startswith("scripts/lab import-data ")]
    out_dir = tmp_path / "build"
    out_dir.mkdir()
    command = f"cd {ROOT} && " + line.replace("build/", f"{out_dir}/")
    res = _fresh_shell(command, tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert (out_dir / "trunk.csv").is_file() and (out_dir / "trunk.csv.json").is_file()
    assert not (ROOT / "build" / "trunk.csv.lock").exists()


def test_scripts_lab_keeps_the_callers_directory(tmp_path):
    res = _fresh_shell(f"{ROOT}/scripts/lab defects --random 3 --out rel.toml", tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert (tmp_path / "rel.toml").is_file()
    res = _fresh_shell(f"{ROOT}/scripts/python -c 'import lab, sys; print(sys.prefix)'", tmp_path)
    assert res.returncode == 0, res.stderr[-2000:]
    assert Path(res.stdout.strip()).resolve() == (ROOT / ".venv").resolve()
