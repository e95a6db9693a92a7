"""The README's recipe "Your own robot's data", run as written on the shipped ASL files.

The three commands are read from the README (so the test and the page cannot drift apart),
their ``build/`` outputs redirected into a temporary folder, and run one after the other
with ``python -m lab`` from the repository root, as a fresh clone would. Then the IK step
the recipe names (``track --rig none``) steers the trained model to measured tips.
"""

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import subprocess_env

from lab.data import read_dataset

ROOT = Path(__file__).resolve().parent.parent


def recipe_commands() -> list[list[str]]:
    text = (ROOT / "README.md").read_text()
    section = text.split("### Your own robot's data", 1)[1]
    block = re.search(r"```\n(.*?)```", section, re.S).group(1)
    # a recipe line is `scripts/lab ARGS`, which is `python -m lab ARGS` on .venv
    return [["python", "-m", "lab", *shlex.split(line)[1:]] if line.startswith("scripts/lab ") else shlex.split(line)
            for line in block.splitlines() if line.strip()]  # fmt: skip


@pytest.mark.timeout(300)
def test_readme_recipe_on_the_shipped_asl_files(tmp_path):
    commands = recipe_commands()
    assert [c[3] for c in commands] == ["import-data", "inspect", "train"]
    for argv in commands:
        assert argv[:3] == ["python", "-m", "lab"]
        argv = [a.replace("build/", f"{tmp_path}/") for a in argv[3:]]
        r = subprocess.run(
            [sys.executable, "-m", "lab", *argv], cwd=ROOT, env=subprocess_env(), capture_output=True, text=True,
            timeout=240,
        )  # fmt: skip
        assert r.returncode == 0, f"{shlex.join(argv)}:\n{r.stderr}"
    u, y, meta = read_dataset(tmp_path / "trunk.csv")
    assert u.shape == (669, 6) and meta["robot"]["kind"] == "measured"
    report = json.loads((tmp_path / "trunk.inspect.json").read_text())
    assert 0.005 < report["floor"]["floor_m"] < 0.05  # centimetres, as chapter 10 measures
    targets = y[::97]  # measured tips: the IK step the recipe names, through the trained model, no rig
    (tmp_path / "targets.csv").write_text("x,y,z\n" + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in targets.tolist()))
    track = subprocess.run(
        [sys.executable, "-m", "lab", "track", "--rig", "none", "--model", str(tmp_path / "trunk.npz"),
         "--trajectory", str(tmp_path / "targets.csv"), "--out", str(tmp_path / "trunk.json")],
        cwd=ROOT, env=subprocess_env(), capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert track.returncode == 0, track.stderr
    result = json.loads((tmp_path / "trunk.json").read_text())
    commands = np.array(result["commands"])
    assert commands.shape == (len(targets), 6)
    assert np.all(commands >= u.min(0) - 1e-12) and np.all(commands <= u.max(0) + 1e-12)
