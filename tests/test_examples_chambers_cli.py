"""The PneuNet finger (examples/robots/pneunet.toml: one pressure cavity of a CAD file, two
markers) runs the whole pipeline from the command line: ``simulate`` (every marker, inputs in
Pa), ``train``, ``splits``, ``track`` through the learned model and by Soft IK through the
FEM, ``calibrate --fit softness,density`` on samples of an emulated as-built finger (its
silicone 15 % softer, 20 % denser; solved by our FEM without noise), and ``transfer``.
"""

import csv
import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from lab.cli import main
from lab.data import read_dataset
from lab.description import load_robot

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "robots" / "pneunet.toml"
SOFTER, DENSER = 0.85, 1.2


def as_built(out: Path) -> Path:
    """The finger cast 15 % softer (every Yeoh coefficient) and 20 % denser."""
    text = EXAMPLE.read_text()
    mat = tomllib.loads(text)["material"]
    for key in ("yeoh_c10_pa", "yeoh_c20_pa", "density_kg_m3"):
        factor = DENSER if key == "density_kg_m3" else SOFTER
        line = next(li for li in text.splitlines() if li.startswith(f"{key} ="))
        text = text.replace(line, f"{key} = {factor * mat[key]!r}", 1)
    text = text.replace('mesh_file = "pneunet.geo"', f'mesh_file = "{EXAMPLE.parent / "pneunet.geo"}"')
    out.write_text(text)
    return out


@pytest.mark.slow
def test_pneunet_runs_the_whole_pipeline(tmp_path):
    robot = load_robot(EXAMPLE)
    data, model, out = tmp_path / "data.csv", tmp_path / "model.npz", tmp_path / "track"
    sim = ["simulate", "--robot", str(EXAMPLE), "--jobs", "1", "--no-progress"]
    assert main([*sim, "--grid", "12", "--out", str(data)]) == 0
    u, y, meta = read_dataset(data)
    assert meta["markers"] == ["tip", "middle"] and meta["input_units"] == ["Pa"] and y.shape == (12, 6)
    assert np.all(np.diff(y[:, 2]) < 0)  # more pressure, more curl (tip z falls)

    assert main(["train", str(data), "--hidden", "6", "--out", str(model)]) == 0
    assert main(["splits", str(data), "--hidden", "6", "--n-splits", "2", "--jobs", "1",
                 "--out", str(tmp_path / "splits.csv")]) == 0  # fmt: skip
    targets = tmp_path / "targets.csv"
    mid = 0.5 * (y[1:, :3] + y[:-1, :3])[2::3]  # between the grid's poses: on the reachable curve
    with open(targets, "w", newline="") as f:
        csv.writer(f).writerows([["x", "y", "z"], *mid.tolist()])
    for how in (["--model", str(model)], ["--soft-ik"]):
        assert main(["track", "--robot", str(EXAMPLE), *how, "--trajectory", str(targets), "--rig", "sim",
                     "--out", str(out)]) == 0  # fmt: skip
        result = json.loads(Path(f"{out}.json").read_text() if Path(f"{out}.json").exists() else out.read_text())
        assert result["units"]["commands"] == ["Pa"]
        assert result["mean_error_m"] < (1e-3 if how[0] == "--model" else 1e-4)

    real = tmp_path / "real.csv"
    truth = as_built(tmp_path / "asbuilt.toml")
    assert main(["simulate", "--robot", str(truth), "--jobs", "1", "--no-progress", "--grid", "5",
                 "--out", str(real)]) == 0  # fmt: skip
    fitted = tmp_path / "fitted.toml"
    assert main(["calibrate", "--robot", str(EXAMPLE), str(real), "--fit", "softness,density", "--noise-m", "1e-4",
                 "--out", str(fitted)]) == 0  # fmt: skip
    fit = load_robot(fitted)
    assert fit.yeoh_c_pa[0] / robot.yeoh_c_pa[0] == pytest.approx(SOFTER, rel=0.02)
    assert fit.density_kg_m3 / robot.density_kg_m3 == pytest.approx(DENSER, rel=0.02)

    transferred = tmp_path / "transfer.npz"
    assert main(["transfer", "--method", "finetune", "--sim", str(data), "--real", str(real), "--robot", str(EXAMPLE),
                 "--hidden", "6", "--out", str(transferred)]) == 0  # fmt: skip
    assert transferred.exists()
