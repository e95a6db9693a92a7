"""``python -m lab train DATA --extra-data MORE.csv``: datasets of one robot trained on together."""

import numpy as np
import pytest

from lab.cli import main
from lab.data.dataset import write_dataset
from lab.learn import load_model


def _toy(path, n, seed, robot="toy", m=3):
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 1, (n, m))
    y = np.column_stack([np.sin(u[:, 0]), u[:, 1] * u[:, 2], u.sum(axis=1)]) * 0.01
    write_dataset(path, u, y, {"robot": {"name": robot}})
    return u, y


def test_extra_data_are_appended_and_recorded(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    u_a, y_a = _toy(a, 40, 0)
    u_b, y_b = _toy(b, 25, 1)
    out = tmp_path / "m.npz"
    assert main(["train", str(a), "--extra-data", str(b), "--hidden", "4", "--epochs", "3", "--out", str(out)]) == 0
    training = load_model(out).metadata["training"]
    assert training["n_samples"] == 65
    assert [e["path"] for e in training["data"]["extra"]] == [str(b)]
    # the same data in one file give the same training data hash
    both = tmp_path / "both.csv"
    write_dataset(both, np.vstack([u_a, u_b]), np.vstack([y_a, y_b]), {"robot": {"name": "toy"}})
    out2 = tmp_path / "m2.npz"
    assert main(["train", str(both), "--hidden", "4", "--epochs", "3", "--out", str(out2)]) == 0
    assert load_model(out2).metadata["training"]["data_sha256"] == training["data_sha256"]


@pytest.mark.parametrize("robot, m", [("other", 3), ("toy", 4)])
def test_extra_data_of_another_robot_is_refused(tmp_path, capsys, robot, m):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    _toy(a, 30, 0)
    _toy(b, 30, 1, robot=robot, m=m)
    out = tmp_path / "m.npz"
    assert main(["train", str(a), "--extra-data", str(b), "--epochs", "2", "--out", str(out)]) == 2
    assert "--extra-data" in capsys.readouterr().err
    assert not out.exists()


def test_init_continues_a_network_on_the_same_split(tmp_path, capsys):
    a = tmp_path / "a.csv"
    _toy(a, 60, 0)
    first, more = tmp_path / "first.npz", tmp_path / "more.npz"
    assert main(["train", str(a), "--hidden", "5", "--epochs", "2", "--min-grad", "0", "--out", str(first)]) == 0
    args = ["train", str(a), "--init", str(first), "--epochs", "30", "--min-grad", "0", "--out", str(more)]
    assert main(args) == 0
    t1, t2 = (load_model(p).metadata["training"] for p in (first, more))
    assert t2["split"]["indices"] == t1["split"]["indices"]  # same data and seed: the same split
    assert load_model(more).hidden == (5,)
    assert t2["errors"]["train"]["mse_m2"] < t1["errors"]["train"]["mse_m2"]
    # the output may not be the network it continues, and only an mlp can be continued
    assert main(["train", str(a), "--init", str(first), "--out", str(first)]) == 2
    assert main(["train", str(a), "--init", str(first), "--model", "knn", "--out", str(tmp_path / "k.npz")]) == 2
    assert "--init" in capsys.readouterr().err
