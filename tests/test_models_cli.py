"""lab.learn.models and `python -m lab train/splits --model`: the registry, loading any kind, paired splits."""

import csv
import json

import numpy as np
import pytest

from lab.cli import main
from lab.data.dataset import write_dataset
from lab.learn import load_model
from lab.learn.ensemble import Ensemble
from lab.learn.model_io import ModelFileError
from lab.learn.model_specs import EnsembleSpec, GPRSpec, InverseSpec, KNNSpec, NetworkSpec, model_spec
from lab.learn.models import MODEL_CHOICES, evaluate_model_splits, fit_model, outer_split
from lab.learn.train import train


def arm_like(n=70, seed=0):
    """A smooth 3-motor -> tip map (m) with 0.1 mm noise."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(0, 2, (n, 3))
    y = 0.05 * np.c_[np.sin(u[:, 0]) + 0.3 * u[:, 1], np.cos(u[:, 1]) - 0.2 * u[:, 2], 0.2 * u[:, 0] * u[:, 2]]
    return u, y + 1e-4 * rng.standard_normal(y.shape)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "arm.csv"
    write_dataset(path, *arm_like(), {})
    return path


def test_outer_split_is_trains_split():
    u, y = arm_like()
    for seed in (0, 7):
        ref = train(u, y, (3,), ratios=(0.8, 0.1, 0.1), seed=seed, epochs=1).split
        got = outer_split(len(u), (0.8, 0.1, 0.1), seed)
        for a, b in ((ref.train, got.train), (ref.validation, got.validation), (ref.test, got.test)):
            np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("name", MODEL_CHOICES)
def test_every_model_fits_saves_and_loads_by_kind(name, tmp_path):
    u, y = arm_like(50)
    model = fit_model(model_spec(name, hidden=(4,), seed=1, epochs=10, members=2), u, y)
    assert model.n_u == 3 and model.n_y == 3 and isinstance(model.metadata, dict)
    path = tmp_path / "m.npz"
    model.save(path)
    loaded = load_model(path)
    assert type(loaded) is type(model) and loaded.kind == model.kind
    if name == "inverse-mlp":
        np.testing.assert_allclose(loaded.command(y[:5]), model.command(y[:5]), rtol=1e-12)
    else:
        np.testing.assert_allclose(loaded.predict(u[:5]), model.predict(u[:5]), rtol=1e-12, atol=1e-15)


def test_unknown_kind_and_bad_name(tmp_path):
    u, y = arm_like(30)
    path = tmp_path / "m.npz"
    fit_model(NetworkSpec(hidden=(3,), epochs=2), u, y).save(path)
    with np.load(path) as npz:
        arrays = {k: npz[k] for k in npz.files}
    arrays["metadata"] = np.array(json.dumps({**json.loads(str(arrays["metadata"])), "kind": "lab.banana"}))
    np.savez(tmp_path / "k.npz", **arrays)
    with pytest.raises(ModelFileError, match="kind 'lab.banana'"):
        load_model(tmp_path / "k.npz")
    with pytest.raises(ValueError, match="model must be one of"):
        model_spec("forest")
    with pytest.raises(ValueError, match="no model takes"):
        model_spec("mlp", banana=1)
    with pytest.raises(ValueError, match="spec must be one of"):
        fit_model("mlp", u, y)
    assert model_spec("knn", hidden=(4,), seed=2, n_neighbors=3) == KNNSpec(n_neighbors=3)


def test_model_splits_pair_with_mlp_splits_and_report_the_inverse_through_a_forward_model():
    u, y = arm_like(60)
    mlp = evaluate_model_splits(u, y, NetworkSpec(hidden=(4,), epochs=5), n_splits=2, seed=3)
    knn = evaluate_model_splits(u, y, KNNSpec(), n_splits=2, seed=3)
    assert [r["seed"] for r in mlp] == [r["seed"] for r in knn] and [r["model"] for r in knn] == ["knn", "knn"]
    forward = fit_model(GPRSpec(), u, y)
    inv = evaluate_model_splits(u, y, InverseSpec(hidden=(4,), epochs=5), n_splits=2, seed=3, forward=forward)
    for r, s in zip(inv, knn):
        split = outer_split(len(u), (0.9, 0, 0.1), s["seed"])
        assert r["test_n"] == len(split.test) == s["test_n"]
        assert r["test_mean_command_error_rad"] > 0 and np.isfinite(r["test_mean_distance_m"])
        # the tip error of forward(g(y)) on this split's test targets, recomputed
        g = fit_model(InverseSpec(hidden=(4,), seed=s["seed"], epochs=5), u[split.train], y[split.train])
        d = np.linalg.norm(forward.predict(g.command(y[split.test])) - y[split.test], axis=1)
        assert r["test_mean_distance_m"] == pytest.approx(d.mean(), rel=1e-9)


def test_cli_train_ensemble_br_and_mlp_reports(dataset, tmp_path, capsys):
    out, rep = tmp_path / "e.npz", tmp_path / "e.json"
    args = ["train", str(dataset), "--model", "ensemble", "--members", "2", "--hidden", "4", "--epochs", "10"]
    assert main([*args, "--out", str(out), "--report", str(rep)]) == 0
    printed = capsys.readouterr().out
    assert "within 1 sigma" in printed and "scaled spread" in printed
    r = json.loads(rep.read_text())
    assert r["model_type"] == "ensemble" and r["model"] == str(out)
    assert set(r["calibration_test"]) == {"raw", "scaled", "spread_scale"} and r["test"]["n"] == 7
    ens = load_model(out)
    assert (
        isinstance(ens, Ensemble)
        and len(ens.members) == 2
        and ens.spread_scale == r["calibration_test"]["spread_scale"]
    )
    test = ens.metadata["training"]["split"]["indices"]["test"]
    assert test == outer_split(70, (0.8, 0.1, 0.1), 0).test.tolist()
    out, rep = tmp_path / "b.npz", tmp_path / "b.json"
    assert (
        main(
            [
                "train",
                str(dataset),
                "--algorithm",
                "br",
                "--hidden",
                "5",
                "--epochs",
                "20",
                "--out",
                str(out),
                "--report",
                str(rep),
            ]
        )
        == 0
    )
    r = json.loads(rep.read_text())
    assert r["model_type"] == "mlp" and r["algorithm"] == "br"
    assert 0 < r["bayesian_regularisation"]["gamma"] < r["bayesian_regularisation"]["n_params"]
    assert load_model(out).metadata["training"]["bayesian_regularisation"] == r["bayesian_regularisation"]


def test_cli_splits_models(dataset, tmp_path, capsys):
    rows = {}
    for name, extra in (
        ("mlp", []),
        ("br", ["--algorithm", "br"]),
        ("ensemble", ["--model", "ensemble", "--members", "2"]),
    ):
        out = tmp_path / f"{name}.csv"
        args = ["splits", str(dataset), "--hidden", "4", "--epochs", "8", "--n-splits", "2", "--jobs", "1"]
        assert main([*args, *extra, "--out", str(out)]) == 0
        rows[name] = list(csv.DictReader(out.open()))
        assert "test mean distance over 2 splits" in capsys.readouterr().out
    assert [r["model"] for r in rows["ensemble"]] == ["ensemble"] * 2 and "test_within_1sigma" in rows["ensemble"][0]
    assert [r["seed"] for r in rows["ensemble"]] == [r["seed"] for r in rows["mlp"]] == [r["seed"] for r in rows["br"]]
    assert all(float(r["wall_s"]) > 0 and float(r["test_mean_distance_m"]) > 0 for v in rows.values() for r in v)
    assert rows["br"][0]["command"].endswith("--algorithm br --out " + str(tmp_path / "br.csv"))


def test_cli_bad_model_arguments_exit_2(dataset, tmp_path, capsys):
    out = tmp_path / "m.npz"
    with pytest.raises(SystemExit) as err:
        main(["train", str(dataset), "--model", "forest", "--out", str(out)])
    assert err.value.code == 2 and "invalid choice: 'forest'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as err:
        main(["splits", str(dataset), "--model", "forest", "--out", str(tmp_path / "s.csv")])
    assert err.value.code == 2
    assert main(["train", str(dataset), "--model", "ensemble", "--members", "1", "--out", str(out)]) == 2
    assert "--members must be at least 2" in capsys.readouterr().err
    assert main(["train", str(dataset), "--forward", str(dataset), "--out", str(out)]) == 2
    assert "--forward only applies to --model inverse-mlp" in capsys.readouterr().err
    assert not out.exists()


def test_ensemble_splits_fit_the_spread_scale_on_the_validation_set():
    u, y = arm_like(80)
    rows = evaluate_model_splits(
        u, y, EnsembleSpec(hidden=(4,), epochs=5, members=2), n_splits=2, ratios=(0.7, 0.15, 0.15), seed=1
    )
    for r in rows:
        split = outer_split(len(u), (0.7, 0.15, 0.15), r["seed"])
        ens = fit_model(EnsembleSpec(hidden=(4,), seed=r["seed"], epochs=5, members=2), u[split.train], y[split.train])
        assert r["test_mean_distance_m"] == pytest.approx(
            np.mean(np.linalg.norm(ens.predict(u[split.test]) - y[split.test], axis=1)), rel=1e-9
        )
        assert r["spread_scale"] == pytest.approx(ens.fit_spread_scale(u[split.validation], y[split.validation]))
        assert r["spread_scale"] != 1.0 and 0 <= r["test_raw_within_1sigma"] <= 1


def test_cli_train_peer_and_inverse_judged_by_a_forward_model(dataset, tmp_path, capsys):
    fwd, inv, rep = tmp_path / "knn.npz", tmp_path / "inv.npz", tmp_path / "inv.json"
    assert main(["train", str(dataset), "--model", "knn", "--out", str(fwd)]) == 0
    assert load_model(fwd).kind == "lab.knn"
    args = ["train", str(dataset), "--model", "inverse-mlp", "--hidden", "4", "--epochs", "5", "--forward", str(fwd)]
    assert main([*args, "--out", str(inv), "--report", str(rep)]) == 0
    assert "command err [rad]" in capsys.readouterr().out
    r = json.loads(rep.read_text())
    assert r["model_type"] == "inverse-mlp" and r["layer_sizes"] == [3, 4, 3]
    assert r["test"]["mean_command_error_rad"] > 0 and r["test"]["mean_distance_m"] > 0
    g, f = load_model(inv), load_model(fwd)
    test = g.metadata["training"]["split"]["indices"]["test"]
    from lab.data.dataset import read_dataset

    u, y, _ = read_dataset(dataset)
    d = np.linalg.norm(f.predict(g.command(y[test])) - y[test], axis=1)
    assert r["test"]["mean_distance_m"] == pytest.approx(d.mean(), rel=1e-9)
