"""The two shipped examples of other bodies run the whole pipeline from the command line:
``simulate`` (every marker), ``train``, ``track --rig sim``, and ``calibrate --fit
softness,density`` on samples of an emulated as-built robot.

``examples/robots/tentacle.toml`` is a tapered tentacle hanging under gravity, two tendons
pulled by tension (inputs in N), three markers on stalks; it runs on a coarse mesh (1 ring,
8 layers). ``examples/robots/finger.toml`` is a body meshed by gmsh from ``finger.geo``
(millimetres, clamped at the physical surface "base"), a flexor on a spool and an extensor
held by tension, one marker on a stalk. The emulated as-built robot is the same description
with a softer, denser material (E x 0.8, density x 1.3), its samples solved by our FEM
without noise: calibration must find both factors to within 2 % (measured: below 0.1 %).
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
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "robots"
CASES = {
    "tentacle": (["--n-rings", "1", "--n-axial", "8"], [[0.5, 0.0], [1.0, 0.0], [0.0, 0.75], [0.0, 1.5]]),
    "finger": ([], [[0.5, 0.5], [1.5, 0.5], [2.5, 1.0], [1.0, 1.5]]),
}
SOFTER, DENSER = 0.8, 1.3


def as_built(robot_path: Path, out: Path) -> Path:
    """The example with a softer, denser material: the emulated as-built robot's description."""
    text = robot_path.read_text()
    data = tomllib.loads(text)
    E, rho = data["material"]["youngs_modulus_pa"], data["material"]["density_kg_m3"]
    for key, new in (("youngs_modulus_pa", SOFTER * E), ("density_kg_m3", DENSER * rho)):
        line = next(li for li in text.splitlines() if li.startswith(f"{key} ="))
        text = text.replace(line, f"{key} = {new!r}", 1)
    if "mesh_file" in data["body"]:  # the geometry stays where the example is
        text = text.replace(
            f'mesh_file = "{data["body"]["mesh_file"]}"',
            f'mesh_file = "{robot_path.parent / data["body"]["mesh_file"]}"',
        )  # noqa: E501
    out.write_text(text)
    return out


@pytest.mark.parametrize("name", sorted(CASES))
def test_example_runs_the_whole_pipeline(name, tmp_path):
    robot_path = EXAMPLES / f"{name}.toml"
    robot = load_robot(robot_path)
    mesh, commands = CASES[name]
    data, model, path, out = (tmp_path / n for n in ("data.csv", "model.npz", "path.csv", "track.json"))
    sim = ["simulate", "--robot", str(robot_path), *mesh, "--jobs", "1", "--no-progress"]
    assert main([*sim, "--sobol", "48", "--out", str(data)]) == 0
    u, y, meta = read_dataset(data)
    assert meta["markers"] == list(robot.marker_names) and y.shape == (48, 3 * len(robot.marker_names))
    assert meta["input_units"] == list(robot.input_units)
    assert np.all(u >= 0) and np.all(u <= robot.u_upper)

    # The commands a lab sent, solved in their order: the tips the FEM gives for each.
    sent = tmp_path / "sent.csv"
    with open(sent, "w", newline="") as f:
        csv.writer(f).writerows([[c.name for c in robot.cables], *commands])
    assert main(["simulate", "--robot", str(robot_path), *mesh, "--commands", str(sent), "--out", str(path)]) == 0
    u_sent, y_sent, _ = read_dataset(path)
    fem = ArmFEM(robot, **({"n_rings": 1, "n_axial": 8} if mesh else {}))
    assert np.allclose(y_sent[1], solve_static(fem, np.asarray(commands[1], float)).y_W.ravel(), atol=1e-6)

    assert main(["train", str(data), "--hidden", "8", "--out", str(model)]) == 0
    targets = tmp_path / "targets.csv"
    with open(targets, "w", newline="") as f:
        csv.writer(f).writerows([["x", "y", "z"], *y_sent[:, :3].tolist()])
    assert main(["track", "--robot", str(robot_path), *mesh, "--model", str(model), "--trajectory", str(targets),
                 "--rig", "sim", "--out", str(out)]) == 0  # fmt: skip
    result = json.loads(out.read_text())
    # Tracked to 0.7 mm (finger) and 2.2 mm (tentacle) when measured, by a model of 48 samples.
    assert result["mean_error_m"] < 0.01 and result["units"]["commands"] == list(robot.input_units)

    # Calibration on samples of the emulated as-built robot (a softer, denser material).
    real = tmp_path / "real.csv"
    asbuilt_robot = as_built(robot_path, tmp_path / "asbuilt_true.toml")
    assert main(["simulate", "--robot", str(asbuilt_robot), *mesh, "--jobs", "1", "--no-progress", "--sobol", "8",
                 "--out", str(real)]) == 0  # fmt: skip
    fitted = tmp_path / "fitted.toml"
    assert main(["calibrate", "--robot", str(robot_path), *mesh, str(real), "--fit", "softness,density",
                 "--out", str(fitted)]) == 0  # fmt: skip
    fit = load_robot(fitted)
    assert fit.youngs_modulus_pa / robot.youngs_modulus_pa == pytest.approx(SOFTER, rel=0.02)
    assert fit.density_kg_m3 / robot.density_kg_m3 == pytest.approx(DENSER, rel=0.02)
