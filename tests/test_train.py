"""lab.learn and `python -m lab train`: splits, LM semantics, errors, CLI."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import fd_parameter_jacobian

from lab.cli import main
from lab.data.dataset import read_dataset, write_dataset
from lab.learn.gradient import AdamOptions, LBFGSOptions
from lab.learn.lm import LMOptions, train_lm
from lab.learn.metrics import mean_distance_m, mse_m2, workspace_size_m
from lab.learn.mlp import MLP, load_model
from lab.learn.mlp_init import init_mlp
from lab.learn.split import divide_random
from lab.learn.studies import evaluate_splits, size_sweep, summarize
from lab.learn.train import train
from lab.learn.training_data import TrainingData

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "data" / "sim_three_cable.csv"


@pytest.fixture(scope="module")
def sim_data():
    u, y, _ = read_dataset(DATA)
    return u, y


def smooth_problem(n=60, noise=0.05, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 3, (n, 2))
    y = np.c_[np.sin(u[:, 0]) * np.cos(u[:, 1]), u[:, 0] * u[:, 1] / 9]
    return u, y + noise * rng.standard_normal(y.shape)


# ---- splits and metrics -----------------------------------------------------------------


def test_divide_random_sizes_like_matlab_dividerand():
    s = divide_random(308, (0.8, 0.1, 0.1), seed=0)
    assert s.sizes() == {"train": 246, "validation": 31, "test": 31}  # round(30.8) = 31 each
    assert divide_random(308, (0.9, 0.0, 0.1), seed=0).sizes() == {"train": 277, "validation": 0, "test": 31}
    assert divide_random(308, (70, 15, 15), seed=0).sizes() == {"train": 216, "validation": 46, "test": 46}
    every = np.concatenate([s.train, s.validation, s.test])
    np.testing.assert_array_equal(np.sort(every), np.arange(308))
    again, other = divide_random(308, (0.8, 0.1, 0.1), seed=0), divide_random(308, (0.8, 0.1, 0.1), seed=1)
    np.testing.assert_array_equal(again.test, s.test)
    assert not np.array_equal(other.test, s.test)
    for bad in ((0, 0.5, 0.5), (0.8, -0.1, 0.3), (1, 1)):
        with pytest.raises(ValueError, match="split ratios"):
            divide_random(10, bad)
    with pytest.raises(ValueError, match="no training samples"):
        divide_random(2, (0.2, 0.4, 0.4))


def test_error_metrics_and_workspace_size():
    y = np.zeros((2, 3))
    y_hat = np.array([[3e-3, 4e-3, 0.0], [0.0, 0.0, 1e-3]])
    assert mean_distance_m(y_hat, y) == pytest.approx((5e-3 + 1e-3) / 2)
    assert mse_m2(y_hat, y) == pytest.approx((9e-6 + 16e-6 + 1e-6) / 6)  # mean over 6 elements
    box = np.array([[0.1, -0.05, 0.0], [0.2, 0.05, 0.0], [0.15, 0.0, 0.2]])
    assert workspace_size_m(box) == pytest.approx(np.sqrt(0.1**2 + 0.1**2 + 0.2**2))


# ---- Levenberg-Marquardt semantics --------------------------------------------------------


@pytest.mark.parametrize("hidden", [(3,), (30,)])  # primal (P < N_e) and kernel (P > N_e) forms
def test_first_lm_step_is_the_trainlm_formula_in_data_units(hidden):
    u, y = smooth_problem(n=20)
    y = 0.01 * y + 0.1  # metres-sized outputs: units matter
    model = init_mlp(u, y, hidden, seed=3)
    net, log = train_lm(model, TrainingData(u, y), LMOptions(epochs=1, min_grad=0))
    assert log.history["mu"][0] == 1e-3 and log.stop_reason == "max_epochs"
    n_e = y.size
    J = fd_parameter_jacobian(model, u)
    e = (model.predict(u) - y).ravel()
    mu = 1e-3 * 10.0 ** np.arange(12)
    steps = [np.linalg.solve(J.T @ J / n_e + m * np.eye(len(J.T)), -J.T @ e / n_e) for m in mu]
    mse = lambda th: (model.set_params(th), float(np.mean((model.predict(u) - y) ** 2)))[1]  # noqa: E731
    theta0 = model.get_params()
    k = next(i for i, d in enumerate(steps) if mse(theta0 + d) < log.history["perf"][0])  # first accepted
    np.testing.assert_allclose(net.get_params(), theta0 + steps[k], rtol=1e-6, atol=1e-9)
    assert log.history["mu"][1] == pytest.approx(mu[k] * 0.1)
    assert log.history["gradient"][0] == pytest.approx(2 * np.linalg.norm(J.T @ e / n_e), rel=1e-6)


def test_mu_schedule_times_ten_on_failure_tenth_on_success():
    u, y = smooth_problem()
    model = init_mlp(u, y, (8,), seed=1)
    _, log = train_lm(model, TrainingData(u[:40], y[:40], u[40:50], y[40:50], u[50:], y[50:]), LMOptions(min_grad=0))
    ratio = np.log10(log.history["mu"][1:] / log.history["mu"][:-1])
    # one accepted step per epoch: mu * 10^(rejected trials) * 0.1
    np.testing.assert_allclose(ratio, np.round(ratio), atol=1e-9)
    assert ratio.min() == pytest.approx(-1) and ratio.max() >= 0  # both branches happened
    assert np.all(np.diff(log.history["perf"]) < 0)  # every epoch lowered the training MSE


def test_stops_at_mu_max_when_no_step_can_improve():
    # The least-squares optimum, exactly: y_hat = 2 everywhere, J^T e = 0, every step is 0.
    u, y = np.array([[-1.0], [-1.0], [1.0], [1.0]]), np.array([[0.0], [4.0], [4.0], [0.0]])
    model = MLP([np.zeros((1, 1))], [np.zeros(1)], [-1.0], [1.0], [0.0], [4.0])
    _, log = train_lm(model, TrainingData(u, y), LMOptions(min_grad=-1.0))
    assert log.stop_reason == "mu_max" and log.epochs == 1
    assert log.history["mu"][1] == pytest.approx(1e-3 * 10**14)  # x10 until above mu_max = 1e10
    _, log = train_lm(model, TrainingData(u, y))  # gradient 0 <= min_grad comes first
    assert log.stop_reason == "min_grad" and log.epochs == 0


def test_validation_stop_returns_the_best_validation_weights():
    rng = np.random.default_rng(0)
    u, y = rng.uniform(0, 1, (40, 2)), rng.standard_normal((40, 1))  # pure noise: overfits at once
    model = init_mlp(u, y, (10,), seed=1)
    net, log = train_lm(model, TrainingData(u[:30], y[:30], u[30:], y[30:]), LMOptions(min_grad=0))
    h, best = log.history, log.best_epoch
    assert log.stop_reason == "validation"
    assert log.epochs == best + 6 and list(h["val_fail"][best:]) == list(range(7))
    assert h["vperf"][best] == h["vperf"].min() and np.all(h["vperf"][best + 1 :] > h["vperf"][best])
    assert np.mean((net.predict(u[30:]) - y[30:]) ** 2) == pytest.approx(h["vperf"][best], rel=1e-12)
    assert np.mean((net.predict(u[:30]) - y[:30]) ** 2) == pytest.approx(h["perf"][best], rel=1e-12)
    assert h["perf"][-1] < h["perf"][best]  # not the last epoch's weights


def test_kernel_form_and_chunked_primal_form_agree():
    u, y = smooth_problem(n=15)
    model = init_mlp(u, y, (12,), seed=2)  # 50 parameters > 30 residuals
    opts = dict(epochs=10, min_grad=0)
    _, kern = train_lm(model, TrainingData(u, y), LMOptions(**opts))
    net_c, chunk = train_lm(model, TrainingData(u, y), LMOptions(max_jacobian_mb=1e-3, **opts))  # 1-sample chunks
    assert kern.history["perf"][-1] < 1e-6 * kern.history["perf"][0]  # it does interpolate
    np.testing.assert_allclose(kern.history["perf"], chunk.history["perf"], rtol=1e-6)
    np.testing.assert_array_equal(kern.history["mu"], chunk.history["mu"])


def test_train_is_deterministic_and_records_metadata(sim_data):
    u, y = sim_data
    a, b, c = (train(u, y, (6, 6), seed=s, epochs=15) for s in (4, 4, 5))
    np.testing.assert_array_equal(a.model.get_params(), b.model.get_params())
    np.testing.assert_array_equal(a.split.test, b.split.test)
    assert not np.array_equal(a.split.test, c.split.test)
    meta = a.model.metadata["training"]
    assert meta["algorithm"] == "lm" and meta["seed"] == 4 and meta["options"]["mu"] == 1e-3
    assert (meta["split"]["train"], meta["split"]["validation"], meta["split"]["test"]) == (246, 31, 31)
    assert meta["split"]["indices"]["test"] == a.split.test.tolist()
    assert len(meta["data_sha256"]) == 64 and meta["stop_reason"] in ("max_epochs", "min_grad", "validation")
    assert meta["errors"]["test"]["mean_distance_m"] == pytest.approx(
        mean_distance_m(a.model.predict(u[a.split.test]), y[a.split.test])
    )


def test_lm_fits_the_simulated_arm_to_sub_millimetre(sim_data):
    u, y = sim_data
    res = train(u, y, (20, 20), ratios=(0.8, 0.1, 0.1), seed=0)
    size = workspace_size_m(y)
    assert res.errors["test"]["mean_distance_m"] < 1e-3  # < 1 mm (paper, real data: 4.42 mm)
    assert res.errors["test"]["mean_distance_m"] / size < 0.005
    assert res.errors["train"]["mse_m2"] < 1e-7


@pytest.mark.parametrize(
    "algorithm,options", [("lbfgs", LBFGSOptions()), ("adam", AdamOptions(lr=1e-2, batch_size=32))]
)
def test_adam_and_lbfgs_train(sim_data, algorithm, options):
    u, y = sim_data
    init = init_mlp(u, y, (10, 10), seed=np.random.default_rng(0))
    res = train(u, y, (10, 10), algorithm=algorithm, seed=0, epochs=150, options=options)
    before = mean_distance_m(init.predict(u[res.split.test]), y[res.split.test])
    after = res.errors["test"]["mean_distance_m"]
    assert after < 5e-3 and after < 0.1 * before
    assert res.model.metadata["training"]["algorithm"] == algorithm
    h = res.log.history
    assert h["vperf"][res.log.best_epoch] == np.nanmin(h["vperf"])


def test_training_data_checks_shapes_and_fills_missing_sets():
    from lab.errors import InputError

    u, y = np.zeros((5, 3)), np.zeros((5, 2))
    d = TrainingData(u, y)
    assert d.u_val.shape == (0, 3) and d.y_test.shape == (0, 2) and not d.has_validation
    assert TrainingData(u, y, u[:2], y[:2]).has_validation
    for bad in (
        dict(u_train=u, y_train=y[:4]),
        dict(u_train=u[:, 0], y_train=y),
        dict(u_train=u, y_train=y, u_val=u[:2, :2], y_val=y[:2]),
        dict(u_train=u, y_train=y, u_test=u[:2]),
    ):
        with pytest.raises(InputError):
            TrainingData(**bad)
    with pytest.raises(InputError, match="TrainingData"):
        train_lm(init_mlp(u + np.arange(3), y + 1, (2,), seed=0), (u, y))


def test_train_refuses_another_algorithms_options():
    from lab.errors import InputError
    from lab.learn.bayes import BROptions

    u, y = smooth_problem()
    for algorithm, options in (
        ("lm", BROptions()),
        ("br", LMOptions()),
        ("adam", {"lr": 1e-2}),
        ("lbfgs", AdamOptions()),
    ):
        with pytest.raises(InputError, match="options of type"):
            train(u, y, (3,), algorithm=algorithm, options=options, epochs=1)
    with pytest.raises(InputError, match="must be of type LMOptions"):
        train_lm(init_mlp(u, y, (2,), seed=0), TrainingData(u, y), BROptions())


# ---- studies ----------------------------------------------------------------------------


def test_evaluate_splits_and_size_sweep_are_reproducible(sim_data):
    u, y = sim_data
    rows = evaluate_splits(u, y, (4,), n_splits=3, seed=1, epochs=10)
    assert [r["split"] for r in rows] == [0, 1, 2] and len({r["seed"] for r in rows}) == 3
    assert all(r["validation_n"] == 0 and r["test_n"] == 31 and r["train_n"] == 277 for r in rows)
    again = evaluate_splits(u, y, (4,), n_splits=3, seed=1, epochs=10, n_jobs=2)
    assert [r["test_mse_m2"] for r in again] == [r["test_mse_m2"] for r in rows]
    sweep = size_sweep(u, y, [2, 3], n_runs=2, seed=0, epochs=5)
    assert [(r["width"], r["run"], r["hidden"]) for r in sweep] == [
        (2, 0, "2-2"),
        (2, 1, "2-2"),
        (3, 0, "3-3"),
        (3, 1, "3-3"),
    ]
    assert sweep[0]["seed"] == sweep[2]["seed"]  # run r: same split for every width
    stats = summarize(sweep, "width", "test_mean_distance_m")
    assert [s["width"] for s in stats] == [2, 3] and stats[0]["n"] == 2
    assert stats[0]["mean"] == pytest.approx(np.mean([r["test_mean_distance_m"] for r in sweep[:2]]))


# ---- command line ---------------------------------------------------------------------------


def test_cli_train_writes_model_and_report(tmp_path, capsys):
    out, report = tmp_path / "model.npz", tmp_path / "report.json"
    rc = main(
        [
            "train",
            str(DATA),
            "--hidden",
            "8",
            "8",
            "--out",
            str(out),
            "--report",
            str(report),
            "--seed",
            "3",
            "--epochs",
            "30",
        ]
    )
    assert rc == 0
    printed = capsys.readouterr().out
    assert "test" in printed and "mean dist [mm]" in printed
    rep = json.loads(report.read_text())
    for key in ("train", "validation", "test"):
        assert set(rep[key]) >= {"mse_m2", "mean_distance_m"}
    model = load_model(out)
    assert model.layer_sizes == (3, 8, 8, 3)
    u, y, _ = read_dataset(DATA)
    test = model.metadata["training"]["split"]["indices"]["test"]
    assert rep["test"]["mean_distance_m"] == pytest.approx(mean_distance_m(model.predict(u[test]), y[test]))
    assert model.metadata["training"]["data"]["file_sha256"] == rep["data_file_sha256"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.npz", "report.json"]


def test_cli_train_bad_inputs_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("u0,u1,u2,x,y,z\n0,0,0,0.1,0.2\n")
    out = tmp_path / "m.npz"
    assert main(["train", str(bad), "--out", str(out)]) == 2
    assert "line 2 has 5 fields" in capsys.readouterr().err
    assert main(["train", str(tmp_path / "missing.csv"), "--out", str(out)]) == 2
    assert "dataset not found" in capsys.readouterr().err
    good = tmp_path / "tiny.csv"
    write_dataset(good, np.zeros((2, 3)), np.zeros((2, 3)), {})
    assert main(["train", str(good), "--out", str(out), "--split", "0.2", "0.4", "0.4"]) == 2
    assert "no training samples" in capsys.readouterr().err
    assert not out.exists()


def test_python_dash_m_lab_train(tmp_path):
    out = tmp_path / "m.npz"
    proc = subprocess.run(
        [sys.executable, "-m", "lab", "train", str(DATA), "--hidden", "5", "--epochs", "5", "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "validation" in proc.stdout and out.exists()
    proc = subprocess.run(
        [sys.executable, "-m", "lab", "train", str(tmp_path / "none.csv"), "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert proc.returncode == 2 and "error: dataset not found" in proc.stderr


def test_cli_splits_writes_one_row_per_split(tmp_path, capsys):
    import csv

    out = tmp_path / "splits.csv"
    rc = main(
        ["splits", str(DATA), "--hidden", "6", "--n-splits", "3", "--jobs", "1", "--seed", "4", "--out", str(out)]
    )
    assert rc == 0
    printed = capsys.readouterr().out
    assert "test mean distance over 3 splits" in printed
    rows = list(csv.DictReader(out.open()))
    assert [int(r["split"]) for r in rows] == [0, 1, 2]
    assert all(int(r["test_n"]) == 31 and r["validation_n"] == "0" for r in rows)  # 90/0/10 of 308
    assert rows[0]["command"].startswith("python -m lab splits")
    # The same numbers as the library call with the same seed.
    u, y, _ = read_dataset(DATA)
    ref = evaluate_splits(u, y, (6,), n_splits=3, seed=4)
    np.testing.assert_allclose(
        [float(r["test_mean_distance_m"]) for r in rows], [r["test_mean_distance_m"] for r in ref], rtol=1e-12
    )
    assert f"{1e3 * np.mean([r['test_mean_distance_m'] for r in ref]):.4f} mm" in printed
    assert main(["splits", str(DATA), "--n-splits", "0", "--out", str(out)]) == 2


# ---- the training spec and the memory check ------------------------------------------------


def test_train_spec_refuses_bad_settings_naming_the_flag():
    from lab.errors import InputError
    from lab.learn.train_spec import TrainSpec

    assert TrainSpec().model_spec().hidden == (20, 20)
    for kwargs, words in (
        (dict(min_grad=float("nan")), "TrainSpec.min_grad"),
        (dict(min_grad=-1.0), "TrainSpec.min_grad"),
        (dict(epochs=0), "TrainSpec.epochs"),
        (dict(hidden=(20, 0)), "TrainSpec.hidden widths must be positive"),
        (dict(ratios=(1.0, -1.0, 0.0)), "TrainSpec.ratios"),
        (dict(ratios=(float("nan"), 0.0, 0.0)), "TrainSpec.ratios"),
        (dict(model="ensemble", members=1), "TrainSpec.members must be at least 2"),
        (dict(seed=-1), "TrainSpec.seed"),
        (dict(jobs=0), "TrainSpec.jobs"),
    ):
        with pytest.raises(InputError, match=words):
            TrainSpec(**kwargs)


def test_network_size_follows_the_lm_system_and_refuses_what_cannot_fit():
    from lab.errors import InputError
    from lab.learn.network_size import check_network_size, n_parameters, training_bytes

    assert n_parameters((3, 20, 20, 3)) == 563
    # 700,003 parameters: on 9 samples LM solves the 27 x 27 kernel system, on 277 the
    # 700,003^2 primal one (terabytes)
    assert training_bytes((3, 100000, 3), 9) < 1e9 < 1e12 < training_bytes((3, 100000, 3), 277)
    assert training_bytes((3, 100000, 3), 277, "adam") < 1e9
    assert check_network_size((3, 20, 20, 3), 277, available_bytes=10**9) < 10**8
    with pytest.raises(InputError, match="TrainSpec.hidden 100000: .* would need about .* of memory"):
        check_network_size((3, 100000, 3), 277, available_bytes=10**10)
    u, y = smooth_problem()
    with pytest.raises(InputError, match="TrainSpec.hidden 100000 100000"):
        train(u, y, (100000, 100000))


# ---- Ctrl-C while the workers start ------------------------------------------------------------


def _loky_workers(parent):
    import psutil

    try:
        children = parent.children(recursive=True)
        return [p for p in children if "popen_loky" in " ".join(p.cmdline())]
    except psutil.Error:  # a child gone meanwhile: look again
        return []


def _has_loaded(process, name: str) -> bool:
    import psutil

    try:
        return any(name in m.path for m in process.memory_maps())
    except psutil.Error:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the workers' memory maps (/proc)")
def test_ctrl_c_while_ensemble_workers_import_exits_130_without_tracebacks(tmp_path):
    # Ctrl-C reaches the whole process group, the workers too; one still importing its modules
    # would print a traceback unless it starts with SIGINT blocked (lab.workers.worker_config).
    # The signal is sent once both workers exist and one is mid-import (psutil's extension is
    # mapped, numpy's and lab's imports are still to come): the window that printed them.
    import os
    import signal

    import psutil
    from helpers import default_sigint, subprocess_env, wait_until

    u, y, meta = read_dataset(DATA)
    data, out = tmp_path / "d.csv", tmp_path / "ens.npz"
    write_dataset(data, u[::5], y[::5], {"robot": meta.get("robot")})
    for _ in range(3):
        proc = subprocess.Popen(
            [sys.executable, "-m", "lab", "train", str(data), "--model", "ensemble", "--jobs", "2", "--out", str(out)],
            cwd=tmp_path,
            env=subprocess_env(),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,  # its own process group, as a terminal's foreground job
            preexec_fn=default_sigint,
        )
        try:
            parent = psutil.Process(proc.pid)

            def importing(parent=parent):
                workers = _loky_workers(parent)
                return len(workers) == 2 and any(_has_loaded(w, "_psutil") for w in workers)

            wait_until(importing, 120, "two loky workers importing their modules")
            os.killpg(proc.pid, signal.SIGINT)
            _, err = proc.communicate(timeout=120)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        assert proc.returncode == 130, err
        assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
        assert "interrupted (Ctrl-C)" in err and not out.exists()


def test_every_trainer_has_one_signature():
    """model, one TrainingData, the algorithm's own options object; nothing else positional."""
    import inspect

    from lab.learn.bayes import train_br
    from lab.learn.gradient import train_adam, train_lbfgs
    from lab.learn.train import ALGORITHM_OPTIONS

    for algorithm, fit in (("lm", train_lm), ("br", train_br), ("adam", train_adam), ("lbfgs", train_lbfgs)):
        params = list(inspect.signature(fit).parameters.values())
        assert [p.name for p in params[:3]] == ["model", "data", "options"], fit.__name__
        assert params[1].annotation == "TrainingData"
        assert params[2].annotation == f"{ALGORITHM_OPTIONS[algorithm].__name__} | None"
        assert all(p.kind is not p.POSITIONAL_OR_KEYWORD for p in params[4:]), fit.__name__
