"""lab.learn.ensemble: the deep ensemble's mean, Jacobians, spread, files and calibration."""

import json
import zipfile

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.errors import InputError
from lab.learn import load_model
from lab.learn.ensemble import Ensemble, load_ensemble, train_ensemble
from lab.learn.mlp import MLP
from lab.learn.model_io import ModelFileError
from lab.learn.spread_calibration import calibration


def random_member(rng, sizes=(3, 6, 5, 3)):
    """A random tanh net with its own normalisation ranges (inputs rad, outputs m)."""
    weights = [1.5 * rng.standard_normal((m, n)) / np.sqrt(n) for n, m in zip(sizes[:-1], sizes[1:])]
    biases = [0.5 * rng.standard_normal(m) for m in sizes[1:]]
    u_min, y_min = rng.uniform(-1.0, 0.0, sizes[0]), rng.uniform(-0.1, 0.1, sizes[-1])
    return MLP(weights, biases, u_min, u_min + rng.uniform(1.0, 3.0, sizes[0]), y_min, y_min + 0.2, "tanh")


@pytest.fixture
def ensemble():
    rng = np.random.default_rng(0)
    return Ensemble([random_member(rng) for _ in range(4)], {"note": "test"})


def test_mean_std_and_shapes(ensemble):
    u = np.random.default_rng(1).uniform(-1, 1, (7, 3))
    f = np.stack([m.predict(u) for m in ensemble.members])  # (K, N, n_y)
    mean, std = ensemble.predict_with_std(u)
    np.testing.assert_allclose(mean, f.mean(axis=0), rtol=1e-14)
    # sample std across the members (ddof 1), written out
    np.testing.assert_allclose(std, np.sqrt(((f - f.mean(axis=0)) ** 2).sum(axis=0) / 3), rtol=1e-12)
    y1, J1 = ensemble.predict_and_jacobian(u[2])
    assert y1.shape == (3,) and J1.shape == (3, 3)
    y, J = ensemble.predict_and_jacobian(u)
    assert y.shape == (7, 3) and J.shape == (7, 3, 3)
    np.testing.assert_allclose(y1, y[2], rtol=1e-13)
    np.testing.assert_allclose(J1, J[2], rtol=1e-12)
    m1, s1 = ensemble.predict_with_std(u[2])
    assert m1.shape == s1.shape == (3,)
    ensemble.spread_scale = 2.5
    np.testing.assert_allclose(ensemble.predict_with_std(u)[1], 2.5 * std, rtol=1e-14)
    np.testing.assert_allclose(ensemble.predict_with_std(u, scaled=False)[1], std, rtol=1e-14)


def test_mean_jacobian_matches_finite_differences_and_torch(ensemble):
    import torch

    u = np.random.default_rng(2).uniform(-1, 1, (9, 3))
    J = ensemble.jacobian(u)
    J_fd = fd_jacobian(ensemble.predict, u)
    assert np.abs(J - J_fd).max() <= 1e-7 * np.abs(J).max()

    def torch_member(m):
        t = lambda a: torch.tensor(a, dtype=torch.float64)  # noqa: E731
        Ws, bs = [t(w) for w in m.weights], [t(b) for b in m.biases]

        def f(x):
            a = (x - t(m.u_min)) * t(m.u_gain) - 1.0
            for W, b in zip(Ws[:-1], bs[:-1]):
                a = torch.tanh(a @ W.T + b)
            return (a @ Ws[-1].T + bs[-1] + 1.0) / t(m.y_gain) + t(m.y_min)

        return f

    fs = [torch_member(m) for m in ensemble.members]
    mean_t = lambda x: sum(f(x) for f in fs) / len(fs)  # noqa: E731
    J_t = torch.func.vmap(torch.func.jacrev(mean_t))(torch.tensor(u)).numpy()
    np.testing.assert_allclose(J, J_t, rtol=1e-10, atol=1e-12 * np.abs(J_t).max())


def test_std_gradient_matches_finite_differences(ensemble):
    ensemble.spread_scale = 1.7
    u = np.random.default_rng(3).uniform(-1, 1, (6, 3))
    std, dstd = ensemble.std_and_jacobian(u)
    np.testing.assert_allclose(std, ensemble.predict_with_std(u)[1], rtol=1e-12)
    d_fd = fd_jacobian(lambda x: ensemble.predict_with_std(x)[1], u)
    assert dstd.shape == (6, 3, 3)
    assert np.abs(dstd - d_fd).max() <= 1e-6 * np.abs(dstd).max()
    s1, d1 = ensemble.std_and_jacobian(u[0])
    np.testing.assert_allclose(d1, dstd[0], rtol=1e-12)


def test_save_load_round_trip_and_dispatch(ensemble, tmp_path):
    ensemble.spread_scale = 3.25
    path = ensemble.save(tmp_path / "e.npz")
    u = np.random.default_rng(4).uniform(-1, 1, (5, 3))
    for loaded in (load_ensemble(path), load_model(path)):
        assert isinstance(loaded, Ensemble) and len(loaded.members) == 4
        assert loaded.spread_scale == 3.25 and loaded.metadata["note"] == "test"
        assert loaded.kind == "lab.ensemble" and loaded.has_jacobian
        for a, b in zip(loaded.predict_with_std(u), ensemble.predict_with_std(u)):
            np.testing.assert_array_equal(a, b)
    with np.load(path) as npz:
        assert "m0.W0" in npz.files and "m3.y_max" in npz.files and not any(k.startswith("m4.") for k in npz.files)
        assert json.loads(str(npz["metadata"]))["kind"] == "lab.ensemble"


def rewrite(src, dst, drop=(), **replace):
    with np.load(src) as npz:
        arrays = {k: npz[k] for k in npz.files if k not in drop}
    arrays.update(replace)
    np.savez(dst, **arrays)
    return dst


def test_corrupt_files_raise_model_file_error(ensemble, tmp_path):
    path = ensemble.save(tmp_path / "e.npz")
    truncated = tmp_path / "t.npz"
    truncated.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(ModelFileError, match="t.npz"):
        load_model(truncated)
    with pytest.raises(ModelFileError, match="missing array 'W1'"):
        load_ensemble(rewrite(path, tmp_path / "w.npz", drop=("m2.W1",)))
    meta = json.loads(str(np.load(path)["metadata"]))
    for bad, match in (
        ({"n_members": 1}, "n_members"),
        ({"spread_scale": -1.0}, "spread_scale"),
        ({"kind": "x"}, "kind"),
    ):
        with pytest.raises(ModelFileError, match=match):
            load_ensemble(rewrite(path, tmp_path / "m.npz", metadata=np.array(json.dumps({**meta, **bad}))))
    with pytest.raises(ModelFileError, match="not found"):
        load_ensemble(tmp_path / "none.npz")
    assert zipfile.is_zipfile(path)


def test_bad_members_are_refused():
    rng = np.random.default_rng(5)
    with pytest.raises(InputError, match="at least 2"):
        Ensemble([random_member(rng)])
    with pytest.raises(InputError, match="different shapes"):
        Ensemble([random_member(rng), random_member(rng, (2, 4, 3))])
    with pytest.raises(InputError, match="spread_scale"):
        Ensemble([random_member(rng), random_member(rng)], spread_scale=0.0)


def test_calibration_of_gaussian_and_over_confident_errors():
    rng = np.random.default_rng(6)
    std = rng.uniform(0.5e-3, 2e-3, (20000, 3))
    mean = rng.normal(0, 0.05, (20000, 3))
    y = mean + std * rng.standard_normal(std.shape)
    c = calibration(y, mean, std)
    assert c["within_1sigma"] == pytest.approx(0.6827, abs=0.006)
    assert c["within_2sigma"] == pytest.approx(0.9545, abs=0.004)
    assert c["radius_within_68"] == pytest.approx(0.6827, abs=0.01)
    assert c["radius_within_95"] == pytest.approx(0.9545, abs=0.006)
    assert c["chi_q68"] == pytest.approx(1.878, abs=1e-3) and c["chi_q95"] == pytest.approx(2.833, abs=1e-3)
    assert c["rms_z"] == pytest.approx(1.0, abs=0.02)
    over = calibration(y, mean, std / 2)  # the spread claims half the real error
    assert over["within_1sigma"] == pytest.approx(0.3829, abs=0.01)  # P(|z| <= 1/2)
    assert over["within_2sigma"] == pytest.approx(0.6827, abs=0.01)
    assert over["radius_within_68"] < 0.3 and over["rms_z"] == pytest.approx(2.0, abs=0.05)
    with pytest.raises(InputError, match="shape"):
        calibration(y, mean, std[:5])


def test_fit_spread_scale_recovers_a_known_scale(ensemble):
    rng = np.random.default_rng(7)
    u = rng.uniform(-1, 1, (4000, 3))
    mean, raw = ensemble.predict_with_std(u, scaled=False)
    y = mean + 3.0 * raw * rng.standard_normal(raw.shape)  # errors three times the raw spread
    assert ensemble.fit_spread_scale(u, y) == pytest.approx(3.0, rel=0.03)
    assert calibration(y, *ensemble.predict_with_std(u))["within_1sigma"] == pytest.approx(0.6827, abs=0.005)
    assert calibration(y, mean, raw)["within_1sigma"] < 0.3


def smooth(n=80, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 2, (n, 3))
    return u, 0.05 * np.c_[np.sin(u[:, 0]) + u[:, 1], np.cos(u[:, 1]) * u[:, 2], u[:, 0] * u[:, 2]]


def test_train_ensemble_members_differ_and_do_not_depend_on_workers():
    u, y = smooth()
    ens = train_ensemble(u, y, hidden=(5,), k=3, seed=2, epochs=15)
    assert len(ens.members) == 3 and ens.metadata["training"]["members"] == 3
    seeds = ens.metadata["training"]["member_seeds"]
    assert len(set(seeds)) == 3 and ens.metadata["training"]["member_ratios"] == [0.9, 0.1, 0.0]
    vals = [tuple(m.metadata["training"]["split"]["indices"]["validation"]) for m in ens.members]
    assert len(set(vals)) == 3  # a different validation split per member
    assert np.all(ens.predict_with_std(u)[1] > 0)
    assert np.mean(np.linalg.norm(ens.predict(u) - y, axis=1)) < 0.2 * np.mean(np.linalg.norm(y - y.mean(0), axis=1))
    par = train_ensemble(u, y, hidden=(5,), k=3, seed=2, epochs=15, n_jobs=2)
    np.testing.assert_array_equal(par.predict(u), ens.predict(u))
    br = train_ensemble(u, y, hidden=(5,), k=2, seed=2, epochs=5, algorithm="br")
    assert br.metadata["training"]["member_ratios"] == [1.0, 0.0, 0.0]
    with pytest.raises(InputError, match="at least 2"):
        train_ensemble(u, y, k=1)
