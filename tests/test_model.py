"""lab.learn.mlp / lab.learn.model_io: forward pass, analytic Jacobians, normalisation, files."""

import json
import zipfile

import numpy as np
import pytest
from helpers import fd_jacobian, fd_parameter_jacobian

from lab.learn.mlp import MLP, load_model, minmax_gain
from lab.learn.mlp_init import init_mlp
from lab.learn.model_io import ModelFileError

ARCHS = [
    ((), "tanh"),
    ((7,), "tanh"),
    ((6,), "logistic"),
    ((20, 20), "tanh"),
    ((5, 8, 4), "logistic"),
    ((9, 3, 6, 5), "tanh"),
]


def random_mlp(rng, sizes, activation, scale=1.0):
    """A random net with non-trivial normalisation ranges (inputs in rad, outputs in m)."""
    weights = [scale * rng.standard_normal((m, n)) / np.sqrt(n) for n, m in zip(sizes[:-1], sizes[1:])]
    biases = [0.5 * rng.standard_normal(m) for m in sizes[1:]]
    u_min = rng.uniform(-1.0, 0.5, sizes[0])
    y_min = rng.uniform(-0.1, 0.1, sizes[-1])
    return MLP(
        weights,
        biases,
        u_min,
        u_min + rng.uniform(0.5, 3.0, sizes[0]),
        y_min,
        y_min + rng.uniform(0.01, 0.2, sizes[-1]),
        activation,
    )


def inputs(rng, model, n):
    span = model.u_max - model.u_min
    return model.u_min - 0.1 * span + 1.2 * span * rng.random((n, model.n_u))


def torch_net(model):
    """The same network in torch (float64), for autograd references."""
    import torch

    t = lambda a: torch.tensor(a, dtype=torch.float64)  # noqa: E731
    Ws, bs = [t(w) for w in model.weights], [t(b) for b in model.biases]
    u_min, u_gain, y_min, y_gain = t(model.u_min), t(model.u_gain), t(model.y_min), t(model.y_gain)
    act = torch.tanh if model.activation == "tanh" else torch.sigmoid

    def f(u):
        a = (u - u_min) * u_gain - 1.0
        for W, b in zip(Ws[:-1], bs[:-1]):
            a = act(a @ W.T + b)
        return (a @ Ws[-1].T + bs[-1] + 1.0) / y_gain + y_min

    return f, Ws, bs


@pytest.mark.parametrize("hidden,activation", ARCHS)
def test_forward_and_jacobian_match_torch_autograd(hidden, activation):
    import torch

    rng = np.random.default_rng(len(hidden) * 10 + len(activation))
    model = random_mlp(rng, (3, *hidden, 2), activation, scale=1.5)
    u = inputs(rng, model, 40)
    f, _, _ = torch_net(model)
    u_t = torch.tensor(u, requires_grad=True)
    J_torch = torch.func.vmap(torch.func.jacrev(f))(u_t).detach().numpy()  # (N, n_y, n_u)
    y, J = model.predict_and_jacobian(u)
    assert J.shape == (40, 2, 3)
    np.testing.assert_allclose(y, f(u_t).detach().numpy(), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(J, J_torch, rtol=1e-10, atol=1e-12 * np.abs(J_torch).max())


@pytest.mark.parametrize("hidden,activation", ARCHS)
def test_jacobian_matches_central_differences(hidden, activation):
    rng = np.random.default_rng(7 + len(hidden))
    model = random_mlp(rng, (4, *hidden, 3), activation)
    u = inputs(rng, model, 25)
    h = 1e-6
    J_fd = fd_jacobian(model.predict, u, h)  # the rows of u are a batch
    J = model.jacobian(u)
    assert np.abs(J - J_fd).max() <= 1e-7 * np.abs(J).max()


def test_single_vector_and_batch_agree():
    rng = np.random.default_rng(1)
    model = random_mlp(rng, (3, 8, 8, 3), "tanh")
    u = inputs(rng, model, 5)
    y, J = model.predict_and_jacobian(u[2])
    assert y.shape == (3,) and J.shape == (3, 3)
    np.testing.assert_allclose(y, model.predict(u)[2], rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(J, model.jacobian(u)[2], rtol=1e-14, atol=1e-15)
    with pytest.raises(ValueError, match="expected u of shape"):
        model.predict(np.zeros((5, 4)))


@pytest.mark.parametrize("hidden,activation", [((), "tanh"), ((6,), "logistic"), ((5, 4), "tanh")])
def test_parameter_jacobian_matches_central_differences(hidden, activation):
    rng = np.random.default_rng(3)
    model = random_mlp(rng, (3, *hidden, 2), activation)
    u = inputs(rng, model, 12)
    y, J = model.parameter_jacobian(u)
    assert J.shape == (12 * 2, model.n_params)
    np.testing.assert_array_equal(y, model.predict(u))
    J_fd = fd_parameter_jacobian(model, u)
    assert np.abs(J - J_fd).max() <= 1e-7 * np.abs(J).max()


def test_parameter_jacobian_matches_torch_and_gradient_is_its_transpose_product():
    import torch

    rng = np.random.default_rng(4)
    model = random_mlp(rng, (3, 6, 5, 3), "logistic")
    u = inputs(rng, model, 9)
    _, J = model.parameter_jacobian(u)
    f, Ws, bs = torch_net(model)
    params = [p for wb in zip(Ws, bs) for p in wb]  # the order of get_params
    for p in params:
        p.requires_grad_(True)
    y_t = f(torch.tensor(u)).reshape(-1)
    rows = [
        torch.cat([g.reshape(-1) for g in torch.autograd.grad(y_t[r], params, retain_graph=True)])
        for r in range(len(y_t))
    ]
    np.testing.assert_allclose(J, torch.stack(rows).numpy(), rtol=1e-10, atol=1e-13)
    v = rng.standard_normal((9, 3))
    np.testing.assert_allclose(model.gradient(u, v), J.T @ v.ravel(), rtol=1e-11, atol=1e-13)


def test_params_round_trip_and_order():
    rng = np.random.default_rng(5)
    model = random_mlp(rng, (3, 4, 2), "tanh")
    theta = model.get_params()
    assert theta.shape == (model.n_params,) == (3 * 4 + 4 + 4 * 2 + 2,)
    np.testing.assert_array_equal(theta[:12], model.weights[0].ravel())  # W_1 row-major, then b_1
    np.testing.assert_array_equal(theta[12:16], model.biases[0])
    model.set_params(theta[::-1].copy())
    np.testing.assert_array_equal(model.get_params(), theta[::-1])
    with pytest.raises(ValueError, match="expected 26 parameters"):
        model.set_params(theta[:-1])


def test_mapminmax_normalisation_maps_data_ranges_to_unit_interval():
    # Identity net in normalised space: y_n = u_n, so u_min -> y_min and u_max -> y_max.
    u_min, u_max = np.array([0.0, -1.0]), np.array([3.0, 1.0])
    y_min, y_max = np.array([0.15, -0.08]), np.array([0.2, 0.08])
    model = MLP([np.eye(2)], [np.zeros(2)], u_min, u_max, y_min, y_max)
    np.testing.assert_allclose(
        model.predict(np.stack([u_min, u_max, (u_min + u_max) / 2])),
        np.stack([y_min, y_max, (y_min + y_max) / 2]),
        rtol=1e-15,
        atol=1e-17,
    )
    np.testing.assert_allclose(model.jacobian(u_min), np.diag((y_max - y_min) / (u_max - u_min)), rtol=1e-15)
    np.testing.assert_array_equal(minmax_gain(np.array([1.0, 2.0]), np.array([1.0, 4.0])), [1.0, 1.0])


def test_init_is_deterministic_nguyen_widrow_and_normalises_to_the_data():
    rng = np.random.default_rng(6)
    u, y = rng.uniform(0, 3, (50, 3)), rng.normal(size=(50, 3))
    a, b, c = (init_mlp(u, y, (20, 20), "tanh", seed=s) for s in (1, 1, 2))
    np.testing.assert_array_equal(a.get_params(), b.get_params())
    assert not np.allclose(a.get_params(), c.get_params())
    np.testing.assert_array_equal(a.u_min, u.min(0))
    np.testing.assert_array_equal(a.y_max, y.max(0))
    # First hidden layer: |w_i| = 0.7 * S^(1/R), scaled by 2 for tanh's active range [-2, 2].
    np.testing.assert_allclose(np.linalg.norm(a.weights[0], axis=1), 2 * 0.7 * 20 ** (1 / 3))
    assert a.layer_sizes == (3, 20, 20, 3) and a.hidden == (20, 20) and a.n_params == 563
    with pytest.raises(ValueError, match="activation"):
        init_mlp(u, y, (4,), "relu")


# ---- files ----------------------------------------------------------------------------


@pytest.fixture
def saved(tmp_path):
    rng = np.random.default_rng(8)
    model = random_mlp(rng, (3, 5, 4, 3), "logistic")
    model.metadata["training"] = {"algorithm": "lm", "epochs": 12, "data_sha256": "ab" * 32}
    path = tmp_path / "m.npz"
    model.save(path)
    return model, path


def test_save_load_round_trip(saved, tmp_path):
    model, path = saved
    loaded = load_model(path)
    u = inputs(np.random.default_rng(0), model, 10)
    np.testing.assert_array_equal(loaded.predict(u), model.predict(u))
    np.testing.assert_array_equal(loaded.jacobian(u), model.jacobian(u))
    assert loaded.activation == "logistic" and loaded.layer_sizes == model.layer_sizes
    assert loaded.metadata["training"] == model.metadata["training"]
    assert loaded.metadata["normalisation"]["method"] == "mapminmax"
    assert "code_version" in loaded.metadata
    with np.load(path, allow_pickle=False) as npz:  # plain arrays, JSON metadata
        meta = json.loads(str(npz["metadata"]))
    assert meta["format_version"] == 1 and meta["architecture"]["layer_sizes"] == [3, 5, 4, 3]
    assert [p.name for p in tmp_path.iterdir()] == ["m.npz"]  # no temporary file left behind


def rewrite(path, out, drop=(), **replace):
    with np.load(path, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files if k not in drop}
    arrays.update(replace)
    with open(out, "wb") as fh:
        np.savez(fh, **arrays)
    return out


def edit_meta(path, out, **changes):
    with np.load(path, allow_pickle=False) as npz:
        meta = json.loads(str(npz["metadata"]))
    meta.update(changes)
    return rewrite(path, out, metadata=np.array(json.dumps(meta)))


def test_missing_file(tmp_path):
    with pytest.raises(ModelFileError, match="not found"):
        load_model(tmp_path / "nope.npz")


def test_truncated_and_corrupt_files(saved, tmp_path):
    _, path = saved
    data = path.read_bytes()
    for name, content in (
        ("truncated", data[: len(data) // 2]),
        ("empty", b""),
        ("garbage", b"not a zip file at all" * 10),
    ):
        bad = tmp_path / f"{name}.npz"
        bad.write_bytes(content)
        with pytest.raises(ModelFileError, match="corrupt or truncated"):
            load_model(bad)
    flipped = bytearray(data)  # damage one member's bytes -> CRC error
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("W1.npy")
    pos = info.header_offset + 30 + len(info.filename) + 100
    flipped[pos] ^= 0xFF
    bad = tmp_path / "flipped.npz"
    bad.write_bytes(bytes(flipped))
    with pytest.raises(ModelFileError):
        load_model(bad)


def test_newer_format_and_bad_metadata(saved, tmp_path):
    _, path = saved
    with pytest.raises(ModelFileError, match="format_version 2 is newer"):
        load_model(edit_meta(path, tmp_path / "v2.npz", format_version=2))
    with pytest.raises(ModelFileError, match="no integer format_version"):
        load_model(edit_meta(path, tmp_path / "v.npz", format_version="1"))
    with pytest.raises(ModelFileError, match="kind"):
        load_model(edit_meta(path, tmp_path / "k.npz", kind="lab.dataset"))
    with pytest.raises(ModelFileError, match="unknown activation 'relu'"):
        load_model(
            edit_meta(path, tmp_path / "a.npz", architecture={"layer_sizes": [3, 5, 4, 3], "activation": "relu"})
        )
    with pytest.raises(ModelFileError, match="corrupt metadata JSON"):
        load_model(rewrite(path, tmp_path / "j.npz", metadata=np.array("{not json")))


def test_missing_inconsistent_or_unsafe_arrays(saved, tmp_path):
    _, path = saved
    with pytest.raises(ModelFileError, match="missing array 'W1'"):
        load_model(rewrite(path, tmp_path / "w.npz", drop=("W1",)))
    with pytest.raises(ModelFileError, match="missing array 'metadata'"):
        load_model(rewrite(path, tmp_path / "nometa.npz", drop=("metadata",)))
    with pytest.raises(ModelFileError, match="missing array 'y_max'"):
        load_model(rewrite(path, tmp_path / "y.npz", drop=("y_max",)))
    with pytest.raises(ModelFileError, match="layer 1 has W"):
        load_model(rewrite(path, tmp_path / "s.npz", W1=np.zeros((4, 4))))
    with pytest.raises(ModelFileError, match="not finite"):
        load_model(rewrite(path, tmp_path / "n.npz", b0=np.full(5, np.nan)))
    with np.load(path, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    arrays["W0"] = np.array([{"evil": 1}], dtype=object)
    pickled = tmp_path / "p.npz"
    with open(pickled, "wb") as fh:
        np.savez(fh, allow_pickle=True, **arrays)
    with pytest.raises(ModelFileError, match="pickled objects"):
        load_model(pickled)
