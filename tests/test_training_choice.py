"""Training that scales with the data: ``--algorithm auto`` picks LM or its sub-sampled form
by size and says so, the sub-sampled LM is LM when it samples every row, small systems run on
one BLAS thread, and an ensemble's members trained on workers equal those trained here and
tell their epochs as they go."""

import json

import numpy as np
import pytest

from lab.cli import main
from lab.learn.algorithm_choice import LM_WORK_LIMIT, blas_threads, choose_algorithm, lm_work
from lab.learn.lm import LMOptions, train_lm
from lab.learn.lm_subsample import LMSubsampleOptions, curvature_rows, train_lm_subsample
from lab.learn.mlp_init import init_mlp
from lab.learn.train import train
from lab.learn.training_data import TrainingData


def smooth(n, n_u=3, seed=0):
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 1, (n, n_u))
    y = 0.05 * np.c_[np.sin(2 * u[:, 0] + u[:, 1]), np.cos(u[:, 1] - u[:, 2]), u[:, 0] * u[:, 2]]
    return u, y + 1e-4 * rng.standard_normal(y.shape)


#: 3-20-20-3 (563 parameters): LM's J^T J passes the limit above 2,103 training rows
SMALL, LARGE = 300, 3000


def test_the_choice_follows_the_work_of_lm():
    sizes = (3, 20, 20, 3)
    assert lm_work(sizes, 277) == 277 * 3 * 563**2
    algorithm, words = choose_algorithm(sizes, 277)
    assert algorithm == "lm" and words.startswith("auto: 831 residuals x 563^2 parameters") and "<=" in words
    algorithm, words = choose_algorithm(sizes, 16000)
    assert algorithm == "lm-subsample" and "> 2e+09" in words
    n = int(LM_WORK_LIMIT // (3 * 563**2))
    assert choose_algorithm(sizes, n)[0] == "lm" and choose_algorithm(sizes, n + 1)[0] == "lm-subsample"
    assert curvature_rows(sizes, 10**6) == n and curvature_rows(sizes, 500) == 500  # at most the set


def test_auto_trains_a_small_set_by_lm_and_a_large_one_by_subsampled_lm():
    u, y = smooth(SMALL)
    auto, lm = train(u, y, algorithm="auto", epochs=3), train(u, y, algorithm="lm", epochs=3)
    assert auto.log.algorithm == "lm" and auto.model.metadata["training"]["algorithm_choice"].startswith("auto: ")
    np.testing.assert_array_equal(auto.model.get_params(), lm.model.get_params())  # LM itself
    u, y = smooth(LARGE)
    big = train(u, y, algorithm="auto", epochs=2, options=LMOptions(min_grad=1e-8, mu=0.01))
    training = big.model.metadata["training"]
    assert big.log.algorithm == training["algorithm"] == "lm-subsample" and "> 2e+09" in training["algorithm_choice"]
    assert training["options"]["rows"] == curvature_rows((3, 20, 20, 3), len(big.split.train)) < len(big.split.train)
    assert training["options"]["min_grad"] == 1e-8 and training["options"]["mu"] == 0.01  # LM's, as changed
    assert training["options"]["max_fail"] == 20  # the sub-sampled LM's own default
    default = train(u, y, algorithm="auto", epochs=1).model.metadata["training"]["options"]
    assert default["min_grad"] == 0 and default["max_fail"] == 20


def test_subsampled_lm_of_every_row_is_lm_and_a_sample_is_seeded():
    u, y = smooth(80, seed=3)
    net = init_mlp(u, y, (6,), seed=2)
    data = TrainingData(u[:60], y[:60], u[60:70], y[60:70], u[70:], y[70:])
    _, lm = train_lm(net, data, LMOptions(epochs=15, min_grad=0))
    _, sub = train_lm_subsample(net, data, LMSubsampleOptions(epochs=15, min_grad=0, rows=60, max_fail=6))
    assert sub.algorithm == "lm-subsample" and sub.options["rows"] == 60
    np.testing.assert_array_equal(sub.history["mu"], lm.history["mu"])
    np.testing.assert_allclose(sub.history["perf"], lm.history["perf"], rtol=1e-9)  # J^T e by backpropagation
    a, log_a = train_lm_subsample(net, data, LMSubsampleOptions(epochs=15, rows=20), seed=5)
    b, _ = train_lm_subsample(net, data, LMSubsampleOptions(epochs=15, rows=20), seed=5)
    c, _ = train_lm_subsample(net, data, LMSubsampleOptions(epochs=15, rows=20), seed=6)
    np.testing.assert_array_equal(a.get_params(), b.get_params())
    assert not np.array_equal(a.get_params(), c.get_params())
    assert log_a.history["perf"][-1] < 0.1 * log_a.history["perf"][0]  # it trains
    with pytest.raises(Exception, match="LMSubsampleOptions.rows"):
        LMSubsampleOptions(rows=0)


def test_small_systems_run_on_one_blas_thread():
    from threadpoolctl import threadpool_info

    with blas_threads(831, 213):
        assert all(p["num_threads"] == 1 for p in threadpool_info() if p["user_api"] == "blas")
    before = [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
    with blas_threads(48000, 683):  # beyond the limit: BLAS keeps its threads
        assert [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] == before


def _dataset(path, n):
    from lab.data import write_dataset

    u, y = smooth(n, seed=1)
    write_dataset(path, u, y, {})
    return path


@pytest.mark.parametrize("n, algorithm", [(SMALL, "lm"), (LARGE, "lm-subsample")])
def test_train_says_which_algorithm_and_how_long(n, algorithm, tmp_path, capsys):
    data = _dataset(tmp_path / "d.csv", n)
    argv = ["train", str(data), "--epochs", "2", "--no-progress", "--out", str(tmp_path / "m.npz")]
    assert main([*argv, "--report", str(tmp_path / "r.json")]) == 0
    err = capsys.readouterr().err
    first = next(line for line in err.splitlines() if "training mlp" in line)
    assert f"training mlp 3-20-20-3 (tanh) with {algorithm} (auto: " in first, err
    assert "estimate: about " in err and "(first epoch " in err, err
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["algorithm"] == algorithm and report["algorithm_choice"].startswith("auto: ")


def test_explicit_algorithm_is_kept_and_not_explained(tmp_path, capsys):
    data = _dataset(tmp_path / "d.csv", LARGE)
    assert main(["train", str(data), "--algorithm", "lm", "--epochs", "1", "--no-progress",
                 "--out", str(tmp_path / "m.npz")]) == 0  # fmt: skip
    err = capsys.readouterr().err
    assert "(tanh) with lm, random split" in err, err


@pytest.mark.parametrize("algorithm", ["br", "lm"])
def test_ensemble_members_on_workers_equal_those_trained_here(algorithm):
    from lab.learn.ensemble import train_ensemble

    u, y = smooth(70, seed=4)
    seen = []
    here = train_ensemble(u, y, (4,), k=3, seed=1, epochs=6, algorithm=algorithm)
    there = train_ensemble(u, y, (4,), k=3, seed=1, epochs=6, algorithm=algorithm, n_jobs=2,
                           progress=lambda d, t: seen.append((d, t)))  # fmt: skip
    for a, b in zip(here.members, there.members):
        np.testing.assert_array_equal(a.get_params(), b.get_params())
    assert seen[0] == (0, 18) and seen[-1] == (18, 18)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)


def test_epoch_counters_add_the_workers_epochs():
    import pickle

    from lab.learn.worker_progress import EpochCounters

    seen = []
    with EpochCounters([5, 5], lambda d, t: seen.append((d, t)), interval_s=1e-3) as counters:
        first = pickle.loads(pickle.dumps(counters.reporter(0)))  # as a worker gets it
        first(0, ())
        first(3, ())
        counters.finished(0)
        counters.reporter(1)(2, ())
        counters.finished(1)
        path = counters.path
    import os

    assert seen[0][0] == 0 and seen[-1] == (10, 10) and not os.path.exists(path)


def test_the_backpropagated_gradient_matches_central_differences():
    from helpers import fd_parameter_jacobian

    from lab.learn.lm_subsample import _error_and_gradient

    u, y = smooth(25, seed=6)
    net = init_mlp(u, y, (4, 5), seed=1)
    e, JE = _error_and_gradient(net, u, y)
    np.testing.assert_allclose(e, net.predict(u) - y, rtol=1e-14)
    J_fd = fd_parameter_jacobian(net, u)
    assert np.abs(JE - J_fd.T @ e.ravel()).max() <= 1e-7 * np.abs(JE).max()
