"""Calibrated physics (lab.transfer): recovering known as-built parameters on a coarse mesh,
the calibrated robot TOML, the description's optional as-built fields, and ``calibrate``."""

import dataclasses
import json
import subprocess
import sys
import tomllib

import numpy as np
import pytest
from helpers import subprocess_env

from lab.asbuilt.arm import as_built_fem, load_defects
from lab.cli import main
from lab.data.dataset import read_dataset, write_dataset
from lab.data.designs import sobol_commands
from lab.description import DescriptionError, load_robot, parse_robot
from lab.fem.model import ArmFEM
from lab.fem.solve.parameters import ParametrisedFEM
from lab.fem.solve.statics import solve_static
from lab.transfer import calibrate, calibrated_robot, prior_std, robot_toml, write_calibrated_robot

MESH = dict(n_rings=1, n_axial=6)
NOISE_M = 1e-4


@pytest.fixture(scope="module")
def truth(three_cable):
    """A known as-built arm (the shipped defects, eyelet shifts scaled to fit the 1-ring mesh),
    its theta, and 30 Sobol commands with exact tips and tips with 0.1 mm noise."""
    d = load_defects(None, three_cable)
    d = dataclasses.replace(d, cables=tuple(dataclasses.replace(c, via_shift_m=0.4 * c.via_shift_m) for c in d.cables))
    fem = as_built_fem(three_cable, d, **MESH)
    pf = ParametrisedFEM(three_cable, **MESH)
    theta = pf.layout.pack(
        d.softness, d.gradient * d.gradient_direction_W[1:], [c.via_shift_m for c in d.cables], d.slack_m
    )
    u = sobol_commands(three_cable, 30, seed=1)
    y = np.array([solve_static(fem, ui).p_tip_W for ui in u])
    noisy = y + NOISE_M * np.random.default_rng(0).standard_normal(y.shape)
    return theta, u, y, noisy


@pytest.fixture(scope="module")
def exact_fit(three_cable, truth):
    theta, u, y, _ = truth
    return calibrate(three_cable, u[:10], y[:10], **MESH, noise_m=1e-6)


def test_recovers_known_parameters_without_noise(exact_fit, truth):
    res, theta = exact_fit, truth[0]
    assert res.converged and res.iterations <= 10 and res.rms_m < 1e-7 < 5e-3 < res.rms_nominal_m
    err = np.abs(res.theta - theta)
    assert np.all(err[:3] < 1e-4)  # log softness and gradient (dimensionless)
    assert np.all(err[3:] < 1e-6)  # eyelet shifts and slack: within 1 um
    assert np.isclose(res.values["softness"], 0.75, rtol=1e-4)


def test_recovers_known_parameters_with_noise_and_uncertainty_shrinks_with_n(three_cable, truth):
    theta, u, _, noisy = truth
    fits = {n: calibrate(three_cable, u[:n], noisy[:n], **MESH, noise_m=NOISE_M) for n in (10, 30)}
    for n, res in fits.items():
        assert res.converged
        assert np.all(np.abs(res.theta - theta) < 4 * res.std), n  # within 4 std of the truth
        assert 0.3 * NOISE_M < res.sigma_m < 2 * NOISE_M  # the residual noise estimate
    res = fits[30]
    err = np.abs(res.theta - theta)
    assert err[0] < 0.02 and np.all(err[1:3] < 0.03)  # softness within 2 %, gradient 0.03
    assert np.all(err[3:-3] < 2e-4) and np.all(err[-3:] < 2e-5)  # shifts within 0.2 mm, slack 20 um
    assert np.all(fits[30].std < fits[10].std)
    assert np.all(res.std < prior_std(res.layout))


def test_prior_keeps_five_samples_well_posed(three_cable, truth):
    theta, u, _, noisy = truth
    res = calibrate(three_cable, u[:5], noisy[:5], **MESH)  # default noise 0.5 mm: prior matters
    assert res.converged and np.all(np.isfinite(res.std)) and res.rms_m < 0.1 * res.rms_nominal_m
    assert np.all(res.std <= res.prior_std)


def test_calibrated_toml_loads_and_simulates_the_calibrated_fem(three_cable, exact_fit, tmp_path, capsys):
    res = exact_fit
    path = tmp_path / "cal.toml"
    robot = write_calibrated_robot(path, three_cable, res, source="real.csv")
    assert robot.sha256 == load_robot(path).sha256 == calibrated_robot(three_cable, res).sha256
    text = path.read_text()
    assert "log_softness" in text and "+-" in text and "stiffness_gradient" in text and "slack_m" in text
    assert (robot.n_rings, robot.n_axial) == (1, 6) and robot.name == three_cable.name
    pf = ParametrisedFEM(three_cable, **MESH)
    u = np.array([1.0, 2.0, 0.5])
    assert np.abs(solve_static(ArmFEM(robot), u).p_tip_W - pf.solve(res.theta, u).p_tip_W).max() < 1e-12
    out = tmp_path / "sim.csv"
    argv = ["simulate", "--robot", str(path), "--sobol", "2", "--jobs", "1", "--no-progress", "--out", str(out)]
    assert main(argv) == 0
    us, ys, meta = read_dataset(out)
    assert meta["robot"]["sha256"] == robot.sha256
    for ui, yi in zip(us, ys):
        assert np.abs(yi - pf.solve(res.theta, ui).p_tip_W).max() < 1e-8


@pytest.mark.parametrize("name", ["three-cable", "six-cable"])
def test_robot_toml_round_trips(name):
    robot = load_robot(name)
    assert parse_robot(tomllib.loads(robot_toml(robot, ["a comment"]))).sha256 == robot.sha256


def test_optional_as_built_fields(three_cable):
    data = tomllib.loads(robot_toml(three_cable))
    unset = dict(data, material=dict(data["material"], stiffness_gradient=[0, 0, 0]))
    unset["cables"] = [dict(c, slack_m=0.0) for c in data["cables"]]
    assert parse_robot(unset).sha256 == three_cable.sha256  # zero is the same as absent
    data["material"]["stiffness_gradient"] = [0.0, 0.1, -0.2]
    data["cables"][1]["slack_m"] = 0.002
    robot = parse_robot(data)
    assert robot.sha256 != three_cable.sha256 and robot.cables[1].slack_m == 0.002
    fem = ArmFEM(robot, **MESH)
    assert np.ptp(fem.elastic.mu) > 0 and fem.cables[1].slack_m == 0.002
    for field, value, match in [
        ("stiffness_gradient", [0.1, 0.0, 0.0], "stiffness_gradient"),
        ("stiffness_gradient", [0.0, 0.8, 0.8], r"\|g\| < 1"),
        ("stiffness_gradient", [0.0, 0.1], "list of 3"),
    ]:
        with pytest.raises(DescriptionError, match=match):
            parse_robot(dict(data, material=dict(data["material"], **{field: value})))
    data["cables"][0]["slack_m"] = 0.05
    with pytest.raises(DescriptionError, match=r"cables\[0\].slack_m"):
        parse_robot(data)
    data["cables"][0]["slack_m"] = "1 mm"
    with pytest.raises(DescriptionError, match=r"cables\[0\].slack_m"):
        parse_robot(data)


def test_calibrate_rejects_bad_data(three_cable):
    u = np.array([[1.0, 1.0, 1.0], [3.0, 3.0, 3.0]])
    with pytest.raises(ValueError, match="sample 1"):
        calibrate(three_cable, u, np.zeros((2, 3)), **MESH)
    with pytest.raises(ValueError, match=r"\(2, 3\)"):
        calibrate(three_cable, u[:1], np.zeros((2, 3)), **MESH)
    with pytest.raises(ValueError, match="prior"):
        calibrate(three_cable, u[:1], np.zeros((1, 3)), **MESH, prior={"slack": 1e-3})


@pytest.fixture()
def real_csv(tmp_path, truth):
    _, u, _, noisy = truth
    path = tmp_path / "real.csv"
    write_dataset(path, u[:6], noisy[:6], {"robot": {"name": "three-cable"}})
    return path


def test_cli_writes_a_calibrated_robot_and_a_summary(real_csv, tmp_path, capsys):
    out, report = tmp_path / "cal.toml", tmp_path / "cal.json"
    argv = ["calibrate", "--robot", "three-cable", str(real_csv), "--out", str(out), "--report", str(report)]
    assert main([*argv, "--n-rings", "1", "--n-axial", "6", "--noise-m", "1e-4"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary == json.loads(report.read_text())
    assert summary["n_samples"] == 6 and summary["rms_m"] < summary["rms_nominal_m"]
    assert set(summary["parameters"]["slack_m[lower-left]"]) == {"value", "std", "nominal", "unit"}
    assert "iteration 1" in captured.err
    robot = load_robot(out)
    assert np.isclose(robot.youngs_modulus_pa, 40e3 * summary["softness"])


def test_cli_refuses_to_overwrite_the_data(real_csv, capsys):
    before = real_csv.read_bytes()
    for out in (real_csv, f"{real_csv}.json"):
        assert main(["calibrate", str(real_csv), "--out", str(out), "--n-rings", "1", "--n-axial", "6"]) == 2
        assert "refusing to overwrite" in capsys.readouterr().err
    assert real_csv.read_bytes() == before


def test_cli_bad_inputs_exit_2(real_csv, tmp_path, capsys):
    out = str(tmp_path / "cal.toml")
    six = tmp_path / "six.csv"
    write_dataset(six, np.zeros((2, 6)), np.zeros((2, 3)), {"robot": {"name": "six-cable"}})
    unsafe = tmp_path / "unsafe.csv"
    write_dataset(unsafe, np.full((1, 3), 2.9), np.zeros((1, 3)), {})
    cases = [
        ([str(tmp_path / "none.csv")], "dataset not found"),
        ([str(real_csv), "--n-rings", "0"], "--n-rings must be a positive integer"),
        ([str(real_csv), "--noise-m", "-1"], "--noise-m"),
        ([str(real_csv), "--robot", "no-such-robot"], "unknown robot"),
        ([str(six)], "six-cable"),
        ([str(unsafe), "--n-rings", "1", "--n-axial", "6"], "unsafe.csv: sample 0"),
    ]
    for args, message in cases:
        assert main(["calibrate", *args, "--out", out]) == 2, args
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, err
    assert not (tmp_path / "cal.toml").exists()


def test_cli_not_converged_exits_1_and_writes_nothing(real_csv, tmp_path, capsys):
    out = tmp_path / "cal.toml"
    argv = ["calibrate", str(real_csv), "--out", str(out), "--n-rings", "1", "--n-axial", "6", "--max-iter", "1"]
    assert main(argv) == 1
    assert "did not converge in 1 iterations" in capsys.readouterr().err and not out.exists()


def test_python_m_lab_calibrate_exit_2_without_traceback(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "lab", "calibrate", str(tmp_path / "none.csv"), "--out", str(tmp_path / "c.toml")],
        capture_output=True,
        text=True,
        timeout=120,
        env=subprocess_env(),
    )
    assert r.returncode == 2 and "dataset not found" in r.stderr and "Traceback" not in r.stderr


def test_transfer_calibrated_writes_a_model_of_the_as_built_arm(three_cable, truth, tmp_path, capsys):
    # the calibrated method: calibrate on 10 noisy samples, re-simulate the --sim commands on
    # the calibrated FEM, train; the network must know the as-built arm far better than one
    # trained on the nominal simulation of the same commands
    from lab.data.designs import grid_commands
    from lab.learn.mlp import load_model
    from lab.learn.train import train

    theta, u, y, noisy = truth
    u_sim = grid_commands(three_cable, 7)
    u_sim = u_sim[three_cable.is_safe(u_sim)]
    fem = ArmFEM(three_cable, **MESH)
    y_sim = np.array([solve_static(fem, ui).p_tip_W for ui in u_sim])
    meta = {"robot": {"name": "three-cable"}}
    sim, real, out = tmp_path / "sim.csv", tmp_path / "real.csv", tmp_path / "cal.npz"
    write_dataset(sim, u_sim, y_sim, meta)
    write_dataset(real, u[:10], noisy[:10], meta)
    argv = ["transfer", "--method", "calibrated", "--sim", str(sim), "--real", str(real), "--robot", "three-cable"]
    assert main([*argv, "--out", str(out), "--n-rings", "1", "--n-axial", "6"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["method"] == "calibrated" and summary["n_real"] == 10
    model = load_model(out)
    meta = model.metadata["transfer"]
    assert meta["n_resimulated"] == len(u_sim) and meta["calibration"]["mesh"] == {"n_rings": 1, "n_axial": 6}
    assert abs(np.log(meta["calibration"]["softness"] / 0.75)) < 0.05
    assert parse_robot(tomllib.loads(meta["calibrated_robot_toml"])).name == "three-cable"
    nominal = train(u_sim, y_sim, (20, 20), seed=0).model
    err_cal = np.linalg.norm(model.predict(u[10:]) - y[10:], axis=1).mean()
    err_nom = np.linalg.norm(nominal.predict(u[10:]) - y[10:], axis=1).mean()
    assert err_cal < 0.3 * err_nom, (err_cal, err_nom)


def test_transfer_calibrated_bad_inputs_exit_2(real_csv, tmp_path, capsys):
    out = str(tmp_path / "m.npz")
    base = ["transfer", "--method", "calibrated", "--real", str(real_csv), "--out", out]
    cases = [
        ([], "--method calibrated needs --robot R and --sim SIM.csv"),
        (["--robot", "three-cable", "--sim-model", str(real_csv)], "not --sim-model"),
        (["--robot", "three-cable", "--sim", str(tmp_path / "none.csv")], "not found"),
    ]
    for args, message in cases:
        assert main([*base, *args]) == 2, args
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, err
    argv = ["transfer", "--method", "finetune", "--real", str(real_csv), "--sim", str(real_csv), "--n-rings", "1"]
    assert main([*argv, "--out", out]) == 2
    assert "options of --method calibrated only" in capsys.readouterr().err


FAMILY_MESH = dict(n_rings=2, n_axial=10)


def test_recovery_on_family_members_beats_the_nominal_in_every_block(three_cable, tmp_path):
    # recovered vs true on two emulated as-built robots of the family (2 x 10 mesh: one ring
    # is too coarse for a stiffness gradient to tell from softness): each
    # block of theta ends closer to the truth than the nominal robot starts
    from lab.asbuilt import RANDOM
    from lab.data.designs import design_commands
    from lab.transfer.recovery import recovery_rows, recovery_summary, true_theta

    u = design_commands(three_cable, 15, "maximin", 0)
    rows = []
    for seed in (0, 1):
        d = RANDOM.defects(three_cable, seed, **FAMILY_MESH)
        pf = ParametrisedFEM(three_cable, **FAMILY_MESH)
        theta = true_theta(pf.layout, d)
        assert np.isclose(np.exp(theta[0]), d.softness) and np.allclose(theta[pf.layout.slack], d.slack_m)
        new = recovery_rows(three_cable, d, u, label=f"random:{seed}", **FAMILY_MESH)
        assert new[0]["parameter"] == "softness" and abs(new[0]["recovered"] / d.softness - 1) < 0.05
        assert new[0]["rms_m"] < 0.3 * new[0]["rms_nominal_m"]
        rows += new
    summary = {s["block"]: s for s in recovery_summary(rows)}
    assert set(summary) == {"softness", "gradient_y", "gradient_z", "eyelet shift", "slack"}
    for s in summary.values():
        assert s["rms_error"] < 0.5 * s["rms_spread"], s
    # the study's table round-trips (numbers, flags), and a bad cell is named by line and column
    from lab.errors import InputError
    from lab.transfer.recovery import read_recovery, robot_coverage, summary_table, write_recovery

    wide = [{**r, "std_inflated": 1e9} for r in rows]
    none_ = [{**r, "std_inflated": 0.0, "model_discrepancy": r["robot"] == "random:1"} for r in rows]
    assert robot_coverage(wide) == {"random:0": (1.0, False), "random:1": (1.0, False)}
    assert robot_coverage(none_) == {"random:0": (0.0, False), "random:1": (0.0, True)}

    table = summary_table(rows).splitlines()  # one line per block under a header, shifts in mm
    assert len(table) == 6 and table[4].split()[:2] == ["eyelet", "shift"] and table[4].count(" mm") == 2

    path = tmp_path / "recovery.csv"
    write_recovery(path, [{"family": "random", **r} for r in rows], {"command": "test"})
    back = read_recovery(path)
    assert len(back) == len(rows) and back[3]["recovered"] == rows[3]["recovered"]
    assert back[0]["model_discrepancy"] is rows[0]["model_discrepancy"] and back[0]["n_real"] == 15
    path.write_text(path.read_text().replace(",False\n", ",maybe\n", 1).replace(",True\n", ",maybe\n", 1))
    with pytest.raises(InputError, match=r"line 2, column 'model_discrepancy'"):
        read_recovery(path)
