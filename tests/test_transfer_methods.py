"""Sim-to-real transfer from data: fine-tuning with its prior, the GP residual
model (Jacobian against central differences, torch autograd and scikit-learn's own
prediction), one-file storage that ``track --model`` reads, and the ``transfer`` command."""

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from helpers import fd_jacobian

from lab.cli import main
from lab.data import read_dataset
from lab.learn import (
    MLP,
    ModelFileError,
    ResidualModel,
    finetune,
    finetune_fixed,
    fit_residual,
    init_mlp,
    load_model,
)
from lab.transfer import transfer_model

ROOT = Path(__file__).resolve().parent.parent
SIM_MODEL = ROOT / "data" / "model_sim_three_cable.npz"
REAL = ROOT / "data" / "real_three_cable.csv"


@pytest.fixture(scope="module")
def data():
    u, y, _ = read_dataset(REAL)
    rng = np.random.default_rng(4)
    idx = rng.permutation(len(u))
    return load_model(SIM_MODEL), u[idx[:30]], y[idx[:30]], u[idx[30:]], y[idx[30:]]


def _mean_mm(model, u, y):
    return 1e3 * float(np.mean(np.linalg.norm(model.predict(u) - y, axis=1)))


def test_residual_jacobian_matches_differences_autograd_and_sklearn(data):
    base, u, y, u_test, _ = data
    model = fit_residual(base, u, y)
    u0 = u_test[:4] + 0.01  # not on a training point
    y_hat, J = model.predict_and_jacobian(u0)
    J_fd = fd_jacobian(model.predict, u0, h=1e-6)
    np.testing.assert_allclose(J, J_fd, rtol=1e-5, atol=1e-9)
    # the GP part alone, through torch autograd
    c = model.correction
    ut = torch.tensor(u0[0], dtype=torch.float64, requires_grad=True)
    d = (ut[None] - torch.tensor(c.X)) / torch.tensor(c.length_scales)
    m = c.signal_variance * torch.exp(-0.5 * (d * d).sum(1)) @ torch.tensor(c.alpha) + torch.tensor(c.offset)
    J_auto = torch.stack([torch.autograd.grad(m[k], ut, retain_graph=True)[0] for k in range(3)]).numpy()
    np.testing.assert_allclose(c.predict_and_jacobian(u0[:1])[1][0], J_auto, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(y_hat, base.predict(u0) + c.predict_and_jacobian(u0)[0], rtol=0, atol=1e-15)


def test_residual_model_reproduces_sklearn_and_beats_the_simulation_net(data):
    from sklearn.gaussian_process import GaussianProcessRegressor

    base, u, y, u_test, y_test = data
    model = fit_residual(base, u, y, seed=3)
    # the stored posterior mean is scikit-learn's: refit with the optimum kernel, no optimiser
    gp = GaussianProcessRegressor(_kernel(model), optimizer=None).fit(u, y - base.predict(u) - model.correction.offset)
    np.testing.assert_allclose(
        model.correction.predict_and_jacobian(u_test)[0] - model.correction.offset, gp.predict(u_test), atol=1e-9
    )
    assert _mean_mm(model, u_test, y_test) < 0.5 * _mean_mm(base, u_test, y_test)


def _kernel(model):
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    c = model.correction
    return ConstantKernel(c.signal_variance, "fixed") * RBF(c.length_scales, "fixed") + WhiteKernel(
        model.metadata["white_noise_m2"], "fixed"
    )


def test_residual_model_is_one_file_load_model_reads(data, tmp_path):
    base, u, y, u_test, _ = data
    model = fit_residual(base, u[:8], y[:8])
    path = model.save(tmp_path / "res.npz")
    back = load_model(path)
    assert isinstance(back, ResidualModel) and back.metadata["n_real"] == 8
    np.testing.assert_array_equal(back.predict(u_test), model.predict(u_test))
    with np.load(path, allow_pickle=False) as npz:  # no pickle, both parts inside
        assert {"base.W0", "gp.X", "metadata"} <= set(npz.files)
    # a damaged GP part is named
    arrays = dict(np.load(path, allow_pickle=False))
    arrays["gp.alpha"] = arrays["gp.alpha"][:-1]
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(ModelFileError, match="bad.npz"):
        load_model(tmp_path / "bad.npz")


def test_finetune_prior_keeps_the_simulation_net_and_last_layer_moves_alone(data):
    base, u, y, *_ = data
    stiff = finetune_fixed(base, u, y, lam=1e6)  # an overwhelming prior: nothing moves
    np.testing.assert_allclose(stiff.get_params(), base.get_params(), atol=1e-8)
    last = finetune_fixed(base, u, y, lam=1e-8, last_layer_only=True)
    n_last = base.weights[-1].size + base.biases[-1].size
    moved = np.abs(last.get_params() - base.get_params()) > 0
    assert not moved[:-n_last].any() and moved[-n_last:].any()
    assert isinstance(last, MLP) and _mean_mm(last, u, y) < _mean_mm(base, u, y)


def test_finetune_chooses_its_prior_by_cross_validation_and_generalises(data):
    base, u, y, u_test, y_test = data
    model = finetune(base, u[:12], y[:12], last_layer_only=True)
    info = model.metadata["finetune"]
    assert info["n_real"] == 12 and info["folds"] == 5
    assert info["lambda"] == min(info["cv_mean_distance_m"], key=info["cv_mean_distance_m"].get)
    assert _mean_mm(model, u_test, y_test) < 0.7 * _mean_mm(base, u_test, y_test)
    with pytest.raises(ValueError, match="at least 2 real samples"):
        finetune(base, u[:1], y[:1])


def test_real_only_and_errors(data):
    base, u, y, u_test, y_test = data
    model = transfer_model("real-only", u[:6], y[:6], hidden=(5,))
    assert model.layer_sizes == (3, 5, 3) and model.metadata["transfer"]["n_real"] == 6
    with pytest.raises(ValueError, match="unknown transfer method"):
        transfer_model("magic", u, y, base)
    with pytest.raises(ValueError, match="starts from a network trained on simulation"):
        transfer_model("residual", u, y, None)


def test_transfer_command_writes_a_model_track_accepts(tmp_path, capsys):
    u, y, _ = read_dataset(REAL)
    real = tmp_path / "real.csv"
    from lab.data import write_dataset

    write_dataset(real, u[:10], y[:10], {"robot": {"name": "three-cable"}})
    out = tmp_path / "res.npz"
    argv = ["transfer", "--method", "residual", "--sim-model", str(SIM_MODEL), "--real", str(real)]
    assert main([*argv, "--robot", "three-cable", "--out", str(out)]) == 0
    report = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert report["n_real"] == 10 and report["method"] == "residual"
    assert isinstance(load_model(out), ResidualModel)
    # outputs never overwrite inputs; a robot mismatch and a missing --sim are bad input
    before = real.read_bytes()
    assert main([*argv, "--out", str(real)]) == 2
    assert real.read_bytes() == before
    assert main([*argv, "--robot", "six-cable", "--out", str(tmp_path / "x.npz")]) == 2
    assert "made on robot 'three-cable'" in capsys.readouterr().err
    assert main(["transfer", "--method", "finetune", "--real", str(real), "--out", str(tmp_path / "y.npz")]) == 2
    assert "needs exactly one of --sim" in capsys.readouterr().err


def test_track_follows_a_circle_with_a_residual_model(tmp_path):
    u, y, _ = read_dataset(REAL)
    model = fit_residual(load_model(SIM_MODEL), u[::10], y[::10])
    path = model.save(tmp_path / "res.npz")
    out = tmp_path / "track.csv"
    code = main(
        ["track", "--model", str(path), "--trajectory", "circle", "--n-points", "6", "--rig", "sim", "--n-rings", "1",
         "--n-axial", "6", "--out", str(out)]
    )  # fmt: skip
    assert code == 0 and out.exists()


def test_init_mlp_still_plain(data):
    # load_model's dispatch leaves plain network files as they were
    base = data[0]
    assert isinstance(base, MLP) and not isinstance(init_mlp(data[1], data[2], (4,)), ResidualModel)


@pytest.mark.parametrize("mu", [1e-20, 1e-3, 1e2])
def test_finetune_step_from_the_gram_matrix_is_the_normal_equations_step(mu):
    # fewer residuals than parameters: the step from the eigendecomposition of Jf Jf^T against a
    # dense solve of the same system, also where Jf's rows are dependent (zero eigenvalues)
    from lab.learn.finetune import _damped_solver

    rng = np.random.default_rng(4)
    Jf, g = rng.normal(size=(12, 40)), rng.normal(size=40)
    n_e, lam = 12, 1e-3
    for J in (Jf, np.vstack([Jf[:8], Jf[:4] * 2.0])):  # rank 12, then rank 8
        dense = np.linalg.solve(J.T @ J / n_e + (lam + mu) * np.eye(40), -g)
        step = _damped_solver(J, n_e, lam, g)(mu)
        assert np.allclose(step, dense, rtol=1e-9, atol=1e-12 * np.abs(dense).max())
    tall = rng.normal(size=(60, 40))  # more residuals than parameters: the dense solve itself
    assert np.allclose(
        _damped_solver(tall, 60, lam, g)(mu), np.linalg.solve(tall.T @ tall / 60 + (lam + mu) * np.eye(40), -g)
    )
