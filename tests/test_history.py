"""lab.learn.history: history features, the past-fixed and at-rest views with exact
Jacobians (central differences and torch autograd), data bounds, and --history in train."""

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.errors import InputError
from lab.learn import Ensemble, fit_gpr, fit_knn
from lab.learn.history import (
    MAX_HISTORY,
    at_rest,
    data_bounds,
    history_features,
    history_of,
    past_commands,
    record_data_bounds,
    record_history,
    with_past,
)
from lab.learn.mlp import MLP

M, K = 2, 2  # motors, past commands


def random_net(rng, sizes):
    """A random tanh net with its own normalisation ranges."""
    weights = [1.5 * rng.standard_normal((b, a)) / np.sqrt(a) for a, b in zip(sizes[:-1], sizes[1:])]
    biases = [0.5 * rng.standard_normal(b) for b in sizes[1:]]
    u_min, y_min = rng.uniform(-1.0, 0.0, sizes[0]), rng.uniform(-0.1, 0.1, sizes[-1])
    return MLP(weights, biases, u_min, u_min + rng.uniform(1.0, 2.0, sizes[0]), y_min, y_min + 0.2, "tanh")


def history_net(seed=0, k=K, m=M):
    net = random_net(np.random.default_rng(seed), (m * (k + 1), 7, 3))
    record_history(net, k, m)
    return net


def torch_f(net):
    """The network in torch (float64), for autograd references."""
    import torch

    t = lambda a: torch.tensor(a, dtype=torch.float64)  # noqa: E731
    Ws, bs = [t(w) for w in net.weights], [t(b) for b in net.biases]
    u_min, u_gain, y_min, y_gain = t(net.u_min), t(net.u_gain), t(net.y_min), t(net.y_gain)

    def f(x):
        a = (x - u_min) * u_gain - 1.0
        for W, b in zip(Ws[:-1], bs[:-1]):
            a = torch.tanh(a @ W.T + b)
        return (a @ Ws[-1].T + bs[-1] + 1.0) / y_gain + y_min

    return f


def test_history_features_repeat_the_sequence_start():
    u = np.arange(12, dtype=float).reshape(6, 2)  # rows 0..5, commands (2i, 2i+1)
    ids = np.array([0, 0, 0, 1, 1, 1])
    x = history_features(u, ids, 2)
    assert x.shape == (6, 6)
    # row 4 (sequence 1 starts at row 3): [u4, u3, u3]
    np.testing.assert_array_equal(x[4], [8, 9, 6, 7, 6, 7])
    np.testing.assert_array_equal(x[2], [4, 5, 2, 3, 0, 1])
    np.testing.assert_array_equal(x[3], [6, 7, 6, 7, 6, 7])
    np.testing.assert_array_equal(history_features(u, ids, 0), u)
    # a sequence is a run of equal consecutive ids: the same numbers need not be sorted
    np.testing.assert_array_equal(history_features(u, [5, 5, 5, 2, 2, 2], 2), x)
    for bad in (-1, MAX_HISTORY + 1, 1.5, True):
        with pytest.raises(InputError, match="history K"):
            history_features(u, ids, bad)
    with pytest.raises(InputError, match="sequence ids"):
        history_features(u, ids[:-1], 1)
    np.testing.assert_array_equal(past_commands(u[:2], 3), u[[1, 0, 0]])


def test_with_past_jacobian_is_the_current_commands_exactly():
    import torch

    net = history_net()
    assert history_of(net) == K and history_of(random_net(np.random.default_rng(1), (2, 4, 3))) == 0
    rng = np.random.default_rng(3)
    past = rng.uniform(-0.5, 0.5, (K, M))
    view = with_past(net, past)
    assert (view.n_u, view.n_y, view.has_jacobian) == (M, 3, True)
    u = rng.uniform(-0.5, 0.5, (5, M))
    y, J = view.predict_and_jacobian(u)
    x = np.hstack([u, np.tile(past.ravel(), (5, 1))])
    np.testing.assert_array_equal(y, net.predict(x))
    np.testing.assert_array_equal(J, net.jacobian(x)[..., :M])  # the base's first m columns
    assert np.abs(J - fd_jacobian(view.predict, u)).max() <= 1e-7 * np.abs(J).max()
    f, p = torch_f(net), torch.tensor(past.ravel())
    J_t = torch.func.vmap(torch.func.jacrev(lambda v: f(torch.cat([v, p]))))(torch.tensor(u)).numpy()
    np.testing.assert_allclose(J, J_t, rtol=1e-10, atol=1e-12 * np.abs(J_t).max())
    y1, J1 = view.predict_and_jacobian(u[1])
    assert y1.shape == (3,) and J1.shape == (3, M)
    np.testing.assert_allclose(J1, J[1], rtol=1e-12)
    # the past matters: another past, another tip
    assert np.abs(with_past(net, past + 0.3).predict(u) - y).max() > 1e-3
    for bad in (past[:1], past.ravel(), np.full((K, M), np.nan)):
        with pytest.raises(InputError, match="the past must be"):
            with_past(net, bad)
    assert not hasattr(view, "predict_with_std") and not hasattr(view, "members")


def test_at_rest_jacobian_is_the_sum_of_the_blocks():
    import torch

    net = history_net(seed=4)
    rest = at_rest(net)
    u = np.random.default_rng(5).uniform(-0.5, 0.5, (4, M))
    y, J = rest.predict_and_jacobian(u)
    np.testing.assert_allclose(y, net.predict(np.tile(u, (1, K + 1))), rtol=1e-14)
    blocks = net.jacobian(np.tile(u, (1, K + 1))).reshape(4, 3, K + 1, M)
    np.testing.assert_allclose(J, blocks.sum(axis=2), rtol=1e-13)
    assert np.abs(J - fd_jacobian(rest.predict, u)).max() <= 1e-7 * np.abs(J).max()
    f = torch_f(net)
    J_t = torch.func.vmap(torch.func.jacrev(lambda v: f(v.repeat(K + 1))))(torch.tensor(u)).numpy()
    np.testing.assert_allclose(J, J_t, rtol=1e-10, atol=1e-12 * np.abs(J_t).max())


def test_views_forward_an_ensembles_spread_with_the_past_fixed():
    from lab.control.spread import has_spread, predicted_spread_m, spread_rows

    members = [history_net(seed=s) for s in range(3)]
    ens = Ensemble(members, {"history": {"k": K, "n_motors": M}}, spread_scale=1.7)
    past = np.array([[0.1, -0.2], [0.3, 0.0]])
    view = with_past(ens, past)
    u = np.array([[0.05, 0.2], [-0.3, 0.1]])
    x = np.hstack([u, np.tile(past.ravel(), (2, 1))])
    assert has_spread(view) and len(view.members) == 3 and view.spread_scale == 1.7
    for a, b in zip(view.predict_with_std(u), ens.predict_with_std(x)):
        np.testing.assert_array_equal(a, b)
    std, dstd = view.std_and_jacobian(u)
    np.testing.assert_array_equal(std, ens.std_and_jacobian(x)[0])
    assert np.abs(dstd - fd_jacobian(lambda v: view.predict_with_std(v)[1], u)).max() <= 1e-6 * np.abs(dstd).max()
    assert predicted_spread_m(view, u[0]) > 0
    r, Jr = spread_rows(view, u[0], 1.0)  # the IK's penalty rows through the members' views
    assert np.abs(Jr - fd_jacobian(lambda v: spread_rows(view, v, 1.0)[0], u[0])).max() <= 1e-6 * np.abs(Jr).max()
    rest = at_rest(ens)
    dstd_r = rest.std_and_jacobian(u)[1]
    assert np.abs(dstd_r - fd_jacobian(lambda v: rest.predict_with_std(v)[1], u)).max() <= 1e-6 * np.abs(dstd_r).max()


def test_views_of_peers_gpr_spread_and_knn_without_a_jacobian():
    rng = np.random.default_rng(6)
    x = rng.uniform(-1, 1, (40, M * 2))
    y = np.stack([np.sin(x[:, 0]) + 0.3 * x[:, 2], x[:, 1] * x[:, 3], np.cos(x[:, 0] + x[:, 1])], axis=1)
    y += 0.01 * rng.standard_normal(y.shape)  # noise: a well-conditioned kernel matrix
    gpr = fit_gpr(x, y, seed=0, n_restarts=0)
    record_history(gpr, 1, M)
    view = with_past(gpr, [[0.2, -0.1]])
    u = rng.uniform(-0.5, 0.5, (3, M))
    J = view.jacobian(u)
    assert np.abs(J - fd_jacobian(view.predict, u)).max() <= 1e-6 * np.abs(J).max()
    mean, std = view.predict_with_std(u, include_noise=False)
    assert mean.shape == std.shape == (3, 3) and not hasattr(view, "std_and_jacobian")
    knn = fit_knn(x, y)
    record_history(knn, 1, M)
    kview = with_past(knn, [[0.2, -0.1]])
    assert not kview.has_jacobian and kview.predict(u).shape == (3, 3)
    with pytest.raises(InputError, match="no useful Jacobian"):
        kview.predict_and_jacobian(u[0])


def test_history_metadata_and_data_bounds_are_checked():
    net = history_net()
    net.metadata["history"] = {"k": K, "n_motors": 3}  # 3 * 3 != 6 inputs
    with pytest.raises(InputError, match="history"):
        history_of(net)
    with pytest.raises(InputError, match="takes 4 inputs, not 6"):
        record_history(random_net(np.random.default_rng(0), (6, 3, 3)), 1, M)
    net = history_net()
    assert data_bounds(net) is None  # saved before bounds were recorded
    record_data_bounds(net, [[-0.5, 0.1], [0.6, 0.2], [0.0, -0.3]])
    lo, hi = data_bounds(net)
    np.testing.assert_array_equal(lo, [-0.5, -0.3])
    np.testing.assert_array_equal(hi, [0.6, 0.2])
    view = with_past(net, np.zeros((K, M)))  # an ordinary model over the current command
    assert history_of(view) == 0 and history_of(at_rest(net)) == 0
    np.testing.assert_array_equal(data_bounds(view)[1], hi)
    plain = random_net(np.random.default_rng(2), (M, 4, 3))
    assert with_past(plain, None).n_u == M and with_past(plain, np.zeros((0, M))).predict(lo).shape == (3,)
    net.metadata["data_bounds"] = {"u_min": [0.0, 0.0], "u_max": [-1.0, 1.0]}
    with pytest.raises(InputError, match="data_bounds"):
        data_bounds(net)


# ---- --history in train and splits, on a dataset of a robot without an FEM ----------------


def measured_dataset(path, n_seq=6, length=12, m=6, seed=0, lag_m=0.04, starts=True):
    """An imported-like dataset: m motors with efforts in [-0.65, 0.65], tips in metres, a
    sidecar with ``robot.kind == "measured"`` and ``sequence_starts``. Hysteretic: the tip
    depends on the previous command of the sequence by up to ``lag_m`` m per coordinate."""
    from lab.data import write_dataset

    rng = np.random.default_rng(seed)
    n = n_seq * length
    u = rng.uniform(-0.65, 0.65, (n, m))
    prev = history_features(u, np.repeat(np.arange(n_seq), length), 1)[:, m:]
    y = 0.1 * np.tanh(u[:, :3] + 0.3 * u[:, 3:6]) + lag_m * prev[:, :3] + np.array([0.0, 0.0, -0.3])
    robot = {"name": "toy-trunk", "kind": "measured", "n_motors": m, "u_min": [-0.65] * m, "u_max": [0.65] * m}
    meta = {"robot": {**robot, "u_unit": "effort", "y_unit": "m"}, "units": {"u": "effort", "xyz": "m"}}
    if starts:
        meta["sequence_starts"] = list(range(0, n, length))
    write_dataset(path, u, y, meta)
    return u, y


def test_history_helps_on_hysteretic_data_and_is_recorded(tmp_path):
    """Measured: the tip depends on the previous command by up to 4 cm; history 1 must cut
    the held-out error (whole sequences held out) several-fold."""
    from lab.jobs.train import run as train_run
    from lab.learn import load_model
    from lab.learn.train_spec import TrainSpec

    data = tmp_path / "hyst.csv"
    u, _ = measured_dataset(data, n_seq=8, length=40)
    err = {}
    for k in (0, 1):
        run = train_run(TrainSpec(hidden=(8,), epochs=60, history=k, ratios=("group",)), data)
        err[k] = run.errors["test"]["mean_distance_m"]
        assert run.report("m.npz")["history"] == k and history_of(run.model) == k
    # measured at this commit: 24.4 mm without history, 0.26 mm with K = 1
    assert err[1] < 0.1 * err[0], err
    run.model.save(tmp_path / "m.npz")
    model = load_model(tmp_path / "m.npz")
    assert model.metadata["history"] == {"k": 1, "n_motors": 6} and model.n_u == 12
    assert model.metadata["robot"]["kind"] == "measured"
    lo, hi = data_bounds(model)
    train_rows = model.metadata["training"]["split"]["indices"]["train"]
    np.testing.assert_array_equal(lo, u[train_rows].min(axis=0))
    np.testing.assert_array_equal(hi, u[train_rows].max(axis=0))


@pytest.mark.parametrize("name", ["mlp", "ensemble", "gpr", "knn", "sklearn-mlp", "inverse-mlp"])
def test_every_model_kind_trains_on_an_imported_dataset(tmp_path, name):
    from lab.jobs.train import run as train_run
    from lab.learn import load_model
    from lab.learn.train_spec import TrainSpec

    data = tmp_path / "trunk.csv"
    u, y = measured_dataset(data, n_seq=5, length=10)
    k = 0 if name == "inverse-mlp" else 1
    spec = TrainSpec(model=name, hidden=(5,), epochs=20, members=2, history=k, ratios=("group", 0.6, 0.2, 0.2))
    run = train_run(spec, data)
    assert run.errors["train"]["n"] + run.errors["validation"]["n"] + run.errors["test"]["n"] == 50
    run.model.save(tmp_path / "m.npz")
    model = load_model(tmp_path / "m.npz")
    assert model.metadata["robot"]["name"] == "toy-trunk" and data_bounds(model)[0].shape == (6,)
    assert np.all(data_bounds(model)[0] >= -0.65) and np.all(data_bounds(model)[0] < 0)
    if name == "inverse-mlp":
        assert "history" not in model.metadata and model.command(y[:2]).shape == (2, 6)
        return
    assert history_of(model) == 1
    view = with_past(model, u[:1])
    np.testing.assert_allclose(view.predict(u[2:4]), model.predict(np.hstack([u[2:4], u[[0, 0]]])), rtol=1e-12)
    if view.has_jacobian:
        J = view.jacobian(u[3])
        assert J.shape == (3, 6)
        assert np.abs(J - fd_jacobian(view.predict, u[3])).max() <= 1e-6 * max(np.abs(J).max(), 1e-3)


def test_history_refusals(tmp_path, capsys):
    from lab.cli import main

    data = tmp_path / "short.csv"
    measured_dataset(data, n_seq=5, length=4)
    out = tmp_path / "m.npz"
    assert main(["train", str(data), "--history", "4", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--history 4: the longest measurement sequence" in err and "has 4 rows" in err
    assert main(["train", str(data), "--history", "1", "--model", "inverse-mlp", "--out", str(out)]) == 2
    assert "--history applies to forward models" in capsys.readouterr().err
    assert main(["splits", str(data), "--history", str(MAX_HISTORY + 1), "--out", str(tmp_path / "s.csv")]) == 2
    assert f"--history must be at most {MAX_HISTORY}" in capsys.readouterr().err
    assert not out.exists()


def test_splits_with_history_writes_its_rows(tmp_path):
    import csv

    from lab.cli import main

    data = tmp_path / "trunk.csv"
    measured_dataset(data, n_seq=6, length=10)
    out = tmp_path / "s.csv"
    argv = ["splits", str(data), "--history", "2", "--hidden", "4", "--epochs", "10", "--n-splits", "2"]
    assert main([*argv, "--jobs", "1", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert [r["history"] for r in rows] == ["2", "2"] and rows[0]["hidden"] == "4"
    assert rows[0]["split_method"] == "random" and int(rows[0]["test_n"]) == 6
