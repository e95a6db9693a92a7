"""The package installs as a plain wheel and runs from outside the repository.

A wheel is built from the repository (no build isolation: no network), installed -- not
editable -- into a fresh virtual environment, and its ``lab`` console script simulates a
small grid in a directory outside the repository. The fresh environment borrows the
test interpreter's third-party packages through a ``.pth`` file, never the repository.
"""

import os
import site
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--no-index",
            "-w",
            str(out),
            str(ROOT),
        ],
        check=True,
        timeout=300,
        cwd=out,
    )
    (path,) = out.glob("softarm_lab-*.whl")
    return path


def test_wheel_contents(wheel):
    with zipfile.ZipFile(wheel) as zf:
        names = set(zf.namelist())
        meta_dir = next(n.split("/")[0] for n in names if n.endswith(".dist-info/METADATA"))
        metadata = zf.read(f"{meta_dir}/METADATA").decode()
        entry_points = zf.read(f"{meta_dir}/entry_points.txt").decode()
    for data in (
        "lab/robots/three-cable.toml",
        "lab/robots/six-cable.toml",
        "lab/rig/defects/three-cable.toml",
        "lab/rigs/hardware-example.toml",
        "lab/cli/__init__.py",
        "lab/fem/model.py",
    ):
        assert data in names, f"{data} missing from the wheel"
    assert not any(n.startswith(("tests/", "notebooks/", "data/")) for n in names)
    assert "lab = lab.__main__:run" in entry_points
    assert "License-Expression: MIT" in metadata and "Name: softarm-lab" in metadata
    assert any(n.endswith("licenses/LICENSE") for n in names)


def test_wheel_installs_and_runs_outside_the_repository(wheel, tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    fresh_site = Path(
        subprocess.run(
            [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    )
    # Third-party packages from this interpreter, but never the repository: the editable
    # install's finder lives in a .pth of ours that a plain path entry does not run.
    ours = {sysconfig.get_paths()["purelib"], *site.getsitepackages()}
    (fresh_site / "borrowed.pth").write_text("\n".join(p for p in sorted(ours) if Path(p).resolve() != ROOT) + "\n")
    # `pip --python` installs into the fresh environment only; `pip install --prefix` would
    # first uninstall the editable install from this interpreter's environment.
    pip = [sys.executable, "-m", "pip", "--python", str(py), "install", "--quiet", "--no-deps", "--no-index"]
    subprocess.run([*pip, str(wheel)], check=True, timeout=300)
    import importlib.metadata

    assert importlib.metadata.version("softarm-lab")  # this environment's own install is untouched
    script = venv / "bin" / "lab"
    assert script.exists()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.update(OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", PATH=f"{venv / 'bin'}:{env.get('PATH', '')}")
    where = subprocess.run(
        [str(py), "-c", "import lab; print(lab.__file__)"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    assert Path(where).is_relative_to(venv), f"imported lab from {where}, not from the wheel"
    assert script.read_text().splitlines()[0] == f"#!{py}"
    r = subprocess.run(
        [
            str(script),
            "simulate",
            "--robot",
            "three-cable",
            "--grid",
            "3",
            "--out",
            "out.csv",
            "--jobs",
            "1",
            "--no-progress",
            "--n-rings",
            "1",
            "--n-axial",
            "6",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    rows = (tmp_path / "out.csv").read_text().splitlines()
    assert rows[0] == "u0,u1,u2,x,y,z" and len(rows) == 1 + 23
    assert (tmp_path / "out.csv.json").exists()
