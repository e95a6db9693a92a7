"""The sim-to-real curve: its measurements on an emulated as-built robot, the
family statistics and findings, the figure, and the resumable ``transfer-curve`` command."""

import csv
import json
from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from lab.cli import main  # noqa: E402
from lab.description import load_robot  # noqa: E402
from lab.learn import load_model  # noqa: E402
from lab.rig.twin import AsBuiltBody  # noqa: E402
from lab.studies.transfer_study import (  # noqa: E402
    curve_rows,
    evaluate_model,
    family_table1,
    findings,
    make_methods,
    quasi_static_tips,
    random_safe_commands,
    read_curve,
    robot_order,
    smallest_n,
)
from lab.viz.transfer import plot_transfer_curve  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SIM_MODEL = ROOT / "data" / "model_sim_three_cable.npz"
COARSE = dict(n_rings=2, n_axial=6)


@pytest.fixture(scope="module")
def body():
    return AsBuiltBody(load_robot("three-cable"), None, **COARSE)


class Oracle:
    """A 'model' that answers with the robot's own settled tips: IK through it must track
    (almost) perfectly, and its model error is zero -- what a wrong evaluation would miss."""

    def __init__(self, body):
        self.body, self.n_u, self.n_y = body, 3, 3
        self.sim = load_model(SIM_MODEL)

    def predict(self, u):
        return quasi_static_tips(self.body, u) if np.ndim(u) == 2 else self.body.quasi_static_tip(u)

    def predict_and_jacobian(self, u):
        # the simulation network's Jacobian is close enough to steer LM; the value is exact
        return self.predict(u), self.sim.jacobian(u)


def test_evaluate_model_measures_tracking_on_the_robot(body):
    u_test = random_safe_commands(body.robot, 8, seed=1)
    tips = quasi_static_tips(body, u_test)
    oracle = evaluate_model(Oracle(body), body, u_test, tips, n_points=6)
    sim = evaluate_model(load_model(SIM_MODEL), body, u_test, tips, n_points=6)
    assert oracle["model_error_m"] == 0.0
    assert oracle["tracking_mean_m"] < 1e-3 < sim["tracking_mean_m"]  # the gap is there, and measured
    assert abs(oracle["size_ratio_mean"] - 1) < 0.05
    assert set(sim) >= {"circle_m", "square_m", "rose_m", "circle_size_ratio", "rose_shift_m", "shift_mean_m"}


def test_curve_rows_use_nested_sample_sets_and_skip_what_a_method_cannot_do(body):
    seen = []

    def spy(u, y):
        seen.append((u.copy(), y.copy()))
        return None if len(u) < 2 else load_model(SIM_MODEL)

    pool = random_safe_commands(body.robot, 6, seed=2)
    rows = curve_rows(body, {"spy": spy}, [0, 3, 6], pool, u_test=pool[:3], noise_sigma_m=1e-4, n_points=4)
    assert [r["n_real"] for r in rows] == [3, 6]
    assert [len(u) for u, _ in seen] == [0, 3, 6]
    np.testing.assert_array_equal(seen[2][0][:3], seen[1][0])  # N = 3 is the start of N = 6
    np.testing.assert_array_equal(seen[2][1][:3], seen[1][1])
    noise = seen[2][1] - quasi_static_tips(body, pool)
    assert 0 < np.abs(noise).max() < 1e-3  # real samples carry motion-capture noise


def _row(robot, method, n, err, size=1.0, shift=0.0):
    r = {"robot": robot, "method": method, "n_real": n, "model_error_m": err, "tracking_mean_m": err}
    r.update({f"{s}_m": err for s in ("circle", "square", "rose")})
    r.update(size_ratio_mean=size, shift_x_m=0.0, shift_y_m=0.0, shift_z_m=shift)
    return r


def test_family_statistics_and_findings():
    rows = [
        _row("random:0", "sim-only", 0, 0.008, size=0.9, shift=0.004),
        _row("random:0", "real-only", 308, 0.002, shift=0.001),
        _row("random:1", "sim-only", 0, 0.010, size=1.1, shift=0.005),
        _row("random:1", "real-only", 308, 0.006, shift=0.001),
        _row("shipped", "sim-only", 0, 0.007),
        _row("random:0", "residual", 10, 0.003),
        _row("random:1", "residual", 10, 0.001),
        _row("random:0", "residual", 30, 0.001),
        _row("random:1", "residual", 30, 0.001),
    ]
    table = {r["condition"]: r for r in family_table1(rows)}
    sim = table["Sim Data + Real Robot"]
    assert sim["n_robots"] == 2 and sim["circle_mean_cm"] == pytest.approx(0.9)
    assert sim["circle_std_cm"] == pytest.approx(np.std([0.8, 1.0], ddof=1))
    assert sim["circle_shipped_cm"] == pytest.approx(0.7) and sim["circle_paper_cm"] == 0.68
    f = {r["robot"]: r for r in findings(rows)}
    assert f["random:0"]["finding_1"] and f["random:0"]["finding_2"]  # 4x worse, smaller, shifted
    assert not f["random:1"]["finding_1"] and not f["random:1"]["finding_2"]  # 1.7x; larger
    assert f["random:1"]["shifted"] and not f["random:1"]["smaller"]  # the parts, apart
    assert list(f) == ["random:0", "random:1"]  # the shipped robot lacks its real-data row
    assert sorted(["random:10", "foam:10", "x", "random:2", "foam:2", "shipped"], key=robot_order) == [
        "shipped",
        "foam:2",
        "foam:10",
        "random:2",
        "random:10",
        "x",
    ]
    assert smallest_n(rows, 0.0015)["residual"] == (30, pytest.approx(0.001))  # N = 10 averages 0.002
    assert smallest_n(rows, 0.0015)["sim-only"] is None


def test_figure_has_a_line_per_method_and_the_paper_references():
    import matplotlib.pyplot as plt

    rows = [
        _row(f"random:{k}", m, n, 0.01 / (1 + n)) for k in range(2) for m in ("finetune", "residual") for n in (5, 30)
    ]
    rows += [_row(f"random:{k}", "sim-only", 0, 0.01) for k in range(2)]
    fig, axes = plot_transfer_curve(rows)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "finetune" in labels and "residual" in labels and any(t.startswith("sim data only") for t in labels)
    assert sum(t.startswith("paper:") for t in labels) == 3
    plt.close(fig)


def test_methods_are_known_or_refused():
    sim = load_model(SIM_MODEL)
    m = make_methods(sim, ["sim-only", "residual"])
    assert m["sim-only"](np.zeros((0, 3)), np.zeros((0, 3))) is sim
    assert m["residual"](np.zeros((0, 3)), np.zeros((0, 3))) is None
    with pytest.raises(ValueError, match="unknown method"):
        make_methods(sim, ["magic"])


def test_transfer_curve_command_writes_and_resumes(tmp_path, capsys):
    out = tmp_path / "curve.csv"
    argv = ["transfer-curve", "--sim-model", str(SIM_MODEL), "--family", "1", "--ns", "0", "4", "--n-test", "4",
            "--n-points", "4", "--methods", "sim-only", "residual", "--n-rings", "1", "--n-axial", "6", "--jobs", "1",
            "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    rows = read_curve(out)
    assert [(r["robot"], r["method"], r["n_real"]) for r in rows] == [
        ("random:0", "sim-only", 0),
        ("random:0", "residual", 4),
    ]
    assert (tmp_path / "curve.csv.json").exists()
    before = out.read_bytes()
    assert main(argv) == 0  # everything there: nothing recomputed, nothing changed
    assert out.read_bytes() == before and "1 already in" in capsys.readouterr().err
    # a method added later: only its rows are measured, the others are kept as they were
    i = argv.index("residual")
    assert main([*argv[: i + 1], "finetune-last", *argv[i + 1 :]]) == 0
    again = read_curve(out)
    assert again[:2] == rows and [(r["method"], r["n_real"]) for r in again[2:]] == [("finetune-last", 4)]
    # never written over an input, and a foreign CSV is not appended to
    assert main([*argv[:-1], str(SIM_MODEL)]) == 2
    other = tmp_path / "other.csv"
    with other.open("w", newline="") as fh:
        csv.writer(fh).writerows([["a", "b"], [1, 2]])
    assert main([*argv[:-1], str(other)]) == 2
    assert "not a transfer-curve file" in capsys.readouterr().err


def test_transfer_curve_foam_family_labels_its_rows(tmp_path):
    out = tmp_path / "foam.csv"
    argv = ["transfer-curve", "--sim-model", str(SIM_MODEL), "--family", "1", "--ns", "0", "--n-test", "1",
            "--n-points", "4", "--methods", "sim-only", "--n-rings", "1", "--n-axial", "6", "--jobs", "1"]  # fmt: skip
    assert main([*argv, "--family-kind", "foam", "--out", str(out)]) == 0
    rows = read_curve(out)
    assert [(r["robot"], r["method"], r["n_real"]) for r in rows] == [("foam:0", "sim-only", 0)]
    assert json.loads((tmp_path / "foam.csv.json").read_text())["family_kind"] == "foam"
    # the same seed of the other family is another robot: the same network errs differently on it
    assert main([*argv, "--out", str(tmp_path / "random.csv")]) == 0
    (random_row,) = read_curve(tmp_path / "random.csv")
    assert random_row["robot"] == "random:0" and random_row["model_error_m"] != rows[0]["model_error_m"]
