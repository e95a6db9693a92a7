"""scikit-learn peers of the network (issue 15): GP, k-NN and MLPRegressor forward models.

Each model reproduces scikit-learn's own prediction after fitting and after a save/load
round trip (NumPy only, no pickle); the GP and MLP Jacobians agree with central
differences and with torch autograd of an independent torch transcription; the GP's
predictive spread is scikit-learn's; k-NN refuses a Jacobian; damaged files are named."""

from pathlib import Path

import numpy as np
import pytest
import torch
from helpers import fd_jacobian

from lab.data import read_dataset
from lab.errors import InputError
from lab.learn import ModelFileError, fit_gpr, fit_knn, fit_sklearn_mlp, init_mlp, load_peer
from lab.learn.peers import KNN_WEIGHTS, GPRModel, KNNModel, SklearnMLPModel

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def data():
    """60 training and 20 held-out samples of the simulated three-cable arm (rad, m)."""
    u, y, _ = read_dataset(ROOT / "data" / "sim_three_cable.csv")
    idx = np.random.default_rng(1).permutation(len(u))
    return u[idx[:60]], y[idx[:60]], u[idx[60:80]], y[idx[60:80]]


@pytest.fixture(scope="module")
def gpr(data):
    return fit_gpr(data[0], data[1], seed=0, n_restarts=1)


@pytest.fixture(scope="module")
def smlp(data):
    return fit_sklearn_mlp(data[0], data[1], hidden=(8, 6), seed=0, max_iter=300)


def _off_grid(u_test):
    return u_test + 0.013  # not on a training sample (k-NN and GP are special there)


def _t(a):
    return torch.tensor(np.asarray(a, float), dtype=torch.float64)


def _autograd_jacobian(f, u0):
    """dy/du (n_y, n_u) of a torch function at one u0, by reverse mode per output."""
    ut = _t(u0).requires_grad_(True)
    y = f(ut)
    return torch.stack([torch.autograd.grad(y[k], ut, retain_graph=True)[0] for k in range(len(y))]).numpy()


def test_gpr_reproduces_sklearn_mean_and_std(gpr, data):
    _, _, u_test, y_test = data
    gp, x = gpr.estimator, gpr.scale(u_test)
    ref_mean, ref_std = gp.predict(x, return_std=True)
    np.testing.assert_allclose(gpr.predict(u_test), ref_mean * gpr.y_scale + gpr.y_mean, rtol=1e-9)
    mean, std = gpr.predict_with_std(u_test)
    np.testing.assert_allclose(mean, gpr.predict(u_test), rtol=1e-12)
    np.testing.assert_allclose(std, ref_std * gpr.y_scale, rtol=1e-6, atol=1e-12)
    assert std.shape == mean.shape == (20, 3) and np.all(std > 0)
    # the noise-free spread is smaller; far outside the data the spread grows to the prior's
    _, std_f = gpr.predict_with_std(u_test, include_noise=False)
    assert np.all(std_f <= std)
    far = gpr.u_max + 50 * (gpr.u_max - gpr.u_min)
    _, std_far = gpr.predict_with_std(far)
    np.testing.assert_allclose(std_far, np.sqrt(gpr.signal_variance + gpr.noise) * gpr.y_scale, rtol=1e-9)
    # and it is a useful model of the arm: held-out error well under the workspace (~0.2 m)
    assert np.mean(np.linalg.norm(gpr.predict(u_test) - y_test, axis=1)) < 2e-3
    assert gpr.metadata["training"]["wall_s"] > 0 and len(gpr.metadata["training"]["length_scales_rad"]) == 3


def test_gpr_jacobian_matches_differences_and_autograd(gpr, data):
    u0 = _off_grid(data[2][:5])
    y, J = gpr.predict_and_jacobian(u0)
    assert y.shape == (5, 3) and J.shape == (5, 3, 3)
    # a larger step than usual: the posterior mean sums large alternating terms (alpha of an
    # ill-conditioned kernel matrix), so round-off, not truncation, limits small steps
    np.testing.assert_allclose(J, fd_jacobian(gpr.predict, u0, h=1e-4), rtol=1e-5, atol=1e-8)
    X, a = _t(gpr.posterior.X), _t(gpr.posterior.alpha)

    def f(u):  # the model written out again, in torch
        x = (u - _t(gpr.u_min)) * _t(gpr.u_gain) - 1.0
        d = (x[None] - X) / _t(gpr.length_scales)
        return gpr.signal_variance * torch.exp(-0.5 * (d * d).sum(1)) @ a * _t(gpr.y_scale) + _t(gpr.y_mean)

    np.testing.assert_allclose(J[2], _autograd_jacobian(f, u0[2]), rtol=1e-9, atol=1e-14)
    # one command in, one out
    y1, J1 = gpr.predict_and_jacobian(u0[2])
    assert y1.shape == (3,) and J1.shape == (3, 3)
    np.testing.assert_array_equal(gpr.jacobian(u0[2]), J1)
    np.testing.assert_allclose(y1, y[2], rtol=1e-10)


def test_gpr_file_round_trip_and_damage(gpr, data, tmp_path):
    _, _, u_test, _ = data
    path = gpr.save(tmp_path / "gp.npz")
    back = load_peer(path)
    assert isinstance(back, GPRModel) and back.estimator is None and back.kind == "lab.gpr"
    np.testing.assert_array_equal(back.predict(u_test), gpr.predict(u_test))
    np.testing.assert_allclose(back.predict_with_std(u_test)[1], gpr.predict_with_std(u_test)[1], rtol=1e-12)
    assert back.metadata["training"]["kernel"] == gpr.metadata["training"]["kernel"]
    arrays = dict(np.load(path, allow_pickle=False))
    np.savez(tmp_path / "short.npz", **{**arrays, "alpha": arrays["alpha"][:-1]})
    with pytest.raises(ModelFileError, match=r"short\.npz.*alpha"):
        load_peer(tmp_path / "short.npz")
    del arrays["noise"]
    np.savez(tmp_path / "nonoise.npz", **arrays)
    with pytest.raises(ModelFileError, match="missing array 'noise'"):
        load_peer(tmp_path / "nonoise.npz")


def test_gpr_refuses_large_data_or_subsamples(data):
    u, y = data[0], data[1]
    with pytest.raises(InputError, match=r"O\(N\^3\).*max_samples=40.*subsample=True"):
        fit_gpr(u, y, max_samples=40)
    small = fit_gpr(u, y, seed=3, n_restarts=0, max_samples=40, subsample=True)
    fit = small.metadata["training"]
    assert len(small.u_train) == 40 and fit["subsampled"] and fit["n_given"] == 60
    # the subset is a subset of the data
    assert all(np.any(np.all(u == row, axis=1)) for row in small.u_train)


def test_knn_matches_sklearn_has_no_jacobian_and_round_trips(data, tmp_path):
    from sklearn.neighbors import KNeighborsRegressor

    u, y, u_test, y_test = data
    knn = fit_knn(u, y, n_neighbors=4)
    assert knn.has_jacobian is False and knn.weights == "distance"
    ref = KNeighborsRegressor(4, weights="distance").fit(knn.scale(u), y).predict(knn.scale(u_test))
    np.testing.assert_allclose(knn.predict(u_test), ref, rtol=1e-14)
    np.testing.assert_allclose(knn.predict(u[7]), y[7], rtol=1e-14)  # exact at a sample
    uniform = fit_knn(u, y, n_neighbors=4, weights="uniform")
    assert not np.allclose(uniform.predict(u[7]), y[7], rtol=1e-6)  # the plain mean is not
    for call in (knn.jacobian, knn.predict_and_jacobian):
        with pytest.raises(InputError, match="no useful Jacobian.*derivative-free"):
            call(u_test[0])
    with pytest.raises(InputError, match="n_neighbors"):
        fit_knn(u[:3], y[:3], n_neighbors=5)
    # The model queries the estimator's k-d tree itself: the same neighbours, ties included
    # (the grid's cell centres are equidistant from eight samples), and the same weights.
    u_grid, y_grid, _ = read_dataset(ROOT / "data" / "sim_three_cable.csv")
    step = np.diff(np.unique(u_grid[:, 0]))[0]
    centres = np.unique(u_grid, axis=0)[:40] + step / 2
    for weights in KNN_WEIGHTS:
        grid = fit_knn(u_grid, y_grid, n_neighbors=5, weights=weights)
        for q in (centres, u_grid[:40], u_test):
            np.testing.assert_allclose(grid.predict(q), grid.estimator.predict(grid.scale(q)), rtol=1e-15, atol=0)
    back = load_peer(knn.save(tmp_path / "knn.npz"))
    assert isinstance(back, KNNModel) and back.n_neighbors == 4
    np.testing.assert_array_equal(back.predict(u_test), knn.predict(u_test))
    assert back.predict(u_test[0]).shape == (3,) and back.predict(u_test).shape == (20, 3)


def test_sklearn_mlp_matches_sklearn_and_its_jacobian_is_exact(smlp, data):
    _, _, u_test, _ = data
    est = smlp.estimator
    np.testing.assert_allclose(
        smlp.predict(u_test), est.predict(smlp.scale(u_test)) * smlp.y_scale + smlp.y_mean, rtol=1e-12
    )
    assert smlp.hidden == (8, 6) and smlp.metadata["training"]["n_iter"] > 0
    u0 = _off_grid(u_test[:4])
    _, J = smlp.predict_and_jacobian(u0)
    np.testing.assert_allclose(J, fd_jacobian(smlp.predict, u0, h=1e-6), rtol=1e-5, atol=1e-9)

    def f(u):  # straight from scikit-learn's coefs_ / intercepts_, in torch
        a = (u - _t(smlp.u_min)) * _t(smlp.u_gain) - 1.0
        for l, (c, b) in enumerate(zip(est.coefs_, est.intercepts_)):
            a = a @ _t(c) + _t(b)
            a = torch.tanh(a) if l < len(est.coefs_) - 1 else a
        return a * _t(smlp.y_scale) + _t(smlp.y_mean)

    np.testing.assert_allclose(J[1], _autograd_jacobian(f, u0[1]), rtol=1e-10, atol=1e-14)


def test_sklearn_mlp_file_round_trip_and_damage(smlp, data, tmp_path):
    _, _, u_test, _ = data
    path = smlp.save(tmp_path / "smlp.npz")
    back = load_peer(path)
    assert isinstance(back, SklearnMLPModel) and back.kind == "lab.sklearn_mlp"
    np.testing.assert_array_equal(back.predict_and_jacobian(u_test)[1], smlp.predict_and_jacobian(u_test)[1])
    arrays = dict(np.load(path, allow_pickle=False))
    arrays["coefs_1"] = arrays["coefs_1"][:-1]
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(ModelFileError, match=r"bad\.npz.*coefs_1"):
        load_peer(tmp_path / "bad.npz")


def test_load_peer_names_the_file_and_problem(data, tmp_path):
    u, y = data[0], data[1]
    with pytest.raises(ModelFileError, match="not found"):
        load_peer(tmp_path / "none.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ModelFileError, match="junk.npz"):
        load_peer(tmp_path / "junk.npz")
    net = init_mlp(u, y, (4,))
    net.save(tmp_path / "net.npz")
    with pytest.raises(ModelFileError, match="'lab.mlp' is not a peer model"):
        load_peer(tmp_path / "net.npz")
    with pytest.raises(InputError, match=r"shape \(N, 3\)"):
        fit_knn(u, y).predict(np.zeros(4))
