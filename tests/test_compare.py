"""``python -m lab compare``: every model on the same splits, resumable, and the polynomial baselines.

A small synthetic dataset (a smooth map of two motors plus 1 mm noise, three sequences)
and the cheap models (linear, poly3, knn, a GP on 108 rows) keep this file to seconds. The
rows must use the same splits for every model (same test sets), history features must
reach the fit, an interrupted run resumes without refitting a row, and a file made with
other settings or from other data is refused. The polynomial's Jacobian is checked
against the shared central differences."""

import json

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.cli import main
from lab.data import read_dataset, write_dataset
from lab.errors import InputError
from lab.studies import model_comparison as mc
from lab.studies.baselines import fit_poly, monomial_exponents
from lab.studies.comparison_spec import CompareSpec, summarise
from lab.studies.model_comparison import read_comparison, run_comparison

CHEAP = ["--n-splits", "2", "--jobs", "1"]


def _tips(u):
    return 0.1 * np.c_[np.sin(1.5 * u[:, 0]), u[:, 1] ** 2 - 0.5 * u[:, 0], u[:, 0] * u[:, 1]]


@pytest.fixture()
def data(tmp_path):
    """120 rows in three sequences of 40; tips in metres with 1 mm noise."""
    rng = np.random.default_rng(0)
    u = rng.uniform(-1, 1, (120, 2))
    path = tmp_path / "d.csv"
    write_dataset(path, u, _tips(u) + rng.normal(0, 1e-3, (120, 3)), {"sequence_starts": [0, 40, 80]})
    return path


def test_poly_fits_a_cubic_exactly_and_its_jacobian_is_exact():
    rng = np.random.default_rng(1)
    u = rng.uniform([-2.0, 0.0, 5.0], [1.0, 3.0, 6.0], (60, 3))
    x = (u - [-0.5, 1.5, 5.5]) / [1.5, 1.5, 0.5]  # the fit's own scaling, written out
    y = np.c_[1 + x[:, 0] * x[:, 1] * x[:, 2], x[:, 0] ** 3 - 2 * x[:, 1], x[:, 2] ** 2 * x[:, 1]]
    model = fit_poly(u, y, 3)
    assert len(monomial_exponents(3, 3)) == 20 and model.metadata["training"]["rank"] == 20
    u_new = rng.uniform([-2.0, 0.0, 5.0], [1.0, 3.0, 6.0], (7, 3))
    x_new = (u_new - [-0.5, 1.5, 5.5]) / [1.5, 1.5, 0.5]
    want = np.c_[
        1 + x_new[:, 0] * x_new[:, 1] * x_new[:, 2], x_new[:, 0] ** 3 - 2 * x_new[:, 1], x_new[:, 2] ** 2 * x_new[:, 1]
    ]
    np.testing.assert_allclose(model.predict(u_new), want, atol=1e-9)
    y_pred, J = model.predict_and_jacobian(u_new)
    np.testing.assert_allclose(y_pred, model.predict(u_new), rtol=1e-12)
    np.testing.assert_allclose(J, fd_jacobian(model.predict, u_new, 1e-6), rtol=1e-6, atol=1e-8)
    # and the analytic Jacobian of the known cubic, d/du = d/dx * (1 / scale)
    x0 = x_new[0]
    dx = np.array(
        [[x0[1] * x0[2], x0[0] * x0[2], x0[0] * x0[1]], [3 * x0[0] ** 2, -2, 0], [0, x0[2] ** 2, 2 * x0[2] * x0[1]]]
    )
    np.testing.assert_allclose(model.jacobian(u_new[0]), dx / [1.5, 1.5, 0.5], rtol=1e-7, atol=1e-9)
    # and torch autograd through the model written out again
    torch = pytest.importorskip("torch")
    ut = torch.tensor(u_new[3], dtype=torch.float64, requires_grad=True)
    xt = (ut - torch.tensor(0.5 * (model.u_min + model.u_max))) * torch.tensor(model.u_gain)
    mono = torch.stack([torch.prod(xt ** torch.tensor(e)) for e in model.exponents])
    yt = mono @ torch.tensor(model.coef)
    J_auto = torch.stack([torch.autograd.grad(yt[i], ut, retain_graph=True)[0] for i in range(3)]).numpy()
    np.testing.assert_allclose(J[3], J_auto, rtol=1e-10, atol=1e-12)
    # a degree-1 fit is the least-squares affine map; a bad degree is refused
    lin = fit_poly(u, y, 1)
    A = np.c_[np.ones(60), u]
    ref = A @ np.linalg.lstsq(A, y, rcond=None)[0]
    np.testing.assert_allclose(lin.predict(u), ref, atol=1e-10)
    for bad in (0, 6, 2.5, True):
        with pytest.raises(InputError, match="degree"):
            fit_poly(u, y, bad)


def test_compare_rows_share_splits_and_use_history(data, tmp_path, capsys):
    out = tmp_path / "c.csv"
    assert (
        main(["compare", str(data), "--models", "linear", "poly3", "knn", *CHEAP, "--ns", "30", "--out", str(out)]) == 0
    )
    rows = read_comparison(out)
    # 3 models x 2 histories x (2 random + 2 random of N = 30 + 2 group + 1 sequential)
    assert len(rows) == 3 * 2 * 7
    by_split = {}
    for r in rows:
        by_split.setdefault((r["split"], r["split_index"], r["n_train"]), set()).add((r["seed"], r["n_test"]))
    assert all(len(v) == 1 for v in by_split.values())  # every model saw the same split
    seq = [r for r in rows if r["split"] == "sequential"]
    assert {(r["n_train"], r["n_test"], r["split_index"]) for r in seq} == {(96, 24, 0)}
    assert {r["n_train"] for r in rows if r["split"] == "random"} == {108, 30}
    assert {r["split"] for r in rows} == {"random", "group", "sequential"}
    group = [r for r in rows if r["split"] == "group"]
    assert {r["n_test"] for r in group} == {40}  # one whole sequence of 40 held out
    full = [r for r in rows if r["n_train"] != 30]

    def rms(model, k):
        return np.mean([r["test_rms_m"] for r in full if r["model"] == model and r["history"] == k])

    assert rms("poly3", 0) < 0.5 * rms("linear", 0) and rms("poly3", 0) < 0.01
    # history 1 gives poly3 more columns: not the same fit (the features reached it)
    assert rms("poly3", 1) != rms("poly3", 0)
    assert all(np.isnan(r["within_1sigma"]) for r in rows)
    side = json.loads(out.with_name("c.csv.json").read_text())
    assert side["kind"] == "lab.model_comparison" and side["dataset"]["n_sequences"] == 3
    assert {(s["split"], s["history"], s["model"]) for s in side["summary"]} >= {("sequential", 1, "knn")}
    assert {c["n_train"] for c in side["learning_curve"]} == {30}
    printed = capsys.readouterr().out
    assert "poly3" in printed and "learning curve" in printed and "rows ->" in printed


def test_interrupted_run_resumes_without_refitting(data, tmp_path, monkeypatch):
    spec = CompareSpec(models=("linear", "poly3", "gpr"), n_splits=2, history=(0, 1))
    full, part = tmp_path / "full.csv", tmp_path / "part.csv"
    run_comparison(spec, data, full)
    fits = []
    real = mc.fit_named
    monkeypatch.setattr(mc, "fit_named", lambda *a: fits.append(a[0]) or real(*a))

    def stop_after_4(line):
        if "test RMS" in line and len(read_comparison(part)) == 4:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_comparison(spec, data, part, log=stop_after_4)
    assert len(read_comparison(part)) == 4 and len(fits) == 4
    fits.clear()
    run_comparison(spec, data, part)
    total = 3 * 2 * 5
    assert len(fits) == total - 4  # the 4 rows in the file were not fitted again
    a, b = read_comparison(full), read_comparison(part)
    key = ("model", "history", "split", "split_index", "n_train")
    a_by = {tuple(r[k] for k in key): r["test_rms_m"] for r in a}
    assert len(b) == total and {tuple(r[k] for k in key): r["test_rms_m"] for r in b} == pytest.approx(a_by)
    gp = [r for r in b if r["model"] == "gpr"]
    assert all(0 <= r["within_1sigma"] <= r["within_2sigma"] <= 1 for r in gp)
    fits.clear()
    run_comparison(spec, data, part)
    assert fits == []


def test_other_settings_or_data_are_refused(data, tmp_path):
    out = tmp_path / "c.csv"
    spec = CompareSpec(models=("linear",), splits=("random",), n_splits=1, history=(0,))
    run_comparison(spec, data, out)
    with pytest.raises(InputError, match=r"test_fraction 0.1 \(this run: 0.2\).*choose another output file"):
        run_comparison(spec.replace(test_fraction=0.2), data, out)
    u, y, meta = read_dataset(data)
    other = tmp_path / "other.csv"
    write_dataset(other, u, y + 1e-3, {k: v for k, v in meta.items() if k == "sequence_starts"})
    with pytest.raises(InputError, match="data_csv_sha256"):
        run_comparison(spec, other, out)
    # more models, histories or splits only add rows
    run_comparison(spec.replace(models=("linear", "knn"), history=(0, 2)), data, out)
    assert len(read_comparison(out)) == 4


def test_one_sequence_is_cut_into_blocks_and_floor_reports_are_checked(tmp_path):
    rng = np.random.default_rng(2)
    u = rng.uniform(-1, 1, (60, 2))
    path = tmp_path / "one.csv"
    write_dataset(path, u, _tips(u), {})
    sha = json.loads((tmp_path / "one.csv.json").read_text())["csv_sha256"]
    report = tmp_path / "r.json"
    report.write_text(json.dumps({"kind": "lab.inspect", "dataset": {"path": "x.csv", "csv_sha256": "0" * 64},
                                  "floor": {"floor_m": 0.002}}))  # fmt: skip
    spec = CompareSpec(models=("poly3",), splits=("group",), n_splits=1, history=(0,))
    with pytest.raises(InputError, match="another dataset"):
        run_comparison(spec, path, tmp_path / "c.csv", floor=report)
    report.write_text(json.dumps({"kind": "lab.inspect", "dataset": {"path": "x.csv", "csv_sha256": sha},
                                  "floor": {"floor_m": 0.002}}))  # fmt: skip
    side = run_comparison(spec, path, tmp_path / "c.csv", floor=report)
    (row,) = read_comparison(tmp_path / "c.csv")
    assert row["split"] == "group(blocks)" and row["n_test"] == 6  # one block of 10
    (s,) = side["summary"]
    assert s["ratio_to_floor"] == pytest.approx(row["test_rms_m"] / 0.002)
    rows = [dict(row, n_train=n, test_rms_m=v) for n, v in ((54, 1.0), (54, 3.0), (20, 5.0))]
    summary, curve = summarise([dict(r, split="random") for r in rows], 54)
    assert summary[0]["test_rms_m"] == 2.0 and curve == [
        {"history": 0, "model": "poly3", "n_train": 20, "n_splits": 1, "test_rms_m": 5.0}
    ]


@pytest.mark.parametrize("sig", ["SIGKILL", "SIGINT"])
def test_killed_or_interrupted_process_resumes(data, tmp_path, sig):
    """A real `python -m lab compare` stopped by kill -9 (or Ctrl-C) after its first rows: the
    file holds only whole rows, the lock does not block the next run, and that run completes
    the table without refitting them (the rows already written keep their values)."""
    import signal
    import subprocess
    import sys

    from helpers import default_sigint, subprocess_env, wait_until

    out = tmp_path / "c.csv"
    argv = [sys.executable, "-m", "lab", "compare", str(data), "--models", "linear", "poly3", "gpr",
            "--history", "0", "1", *CHEAP, "--out", str(out)]  # fmt: skip
    proc = subprocess.Popen(
        argv,
        env=subprocess_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=default_sigint,
    )
    try:
        wait_until(lambda: out.exists() and len(read_comparison(out)) >= 2, timeout_s=120, what="two rows written")
        proc.send_signal(getattr(signal, sig))
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert "Traceback" not in err
    if sig == "SIGINT":
        assert proc.returncode == 130
    first = {(r["model"], r["history"], r["split"], r["split_index"]): r["test_rms_m"] for r in read_comparison(out)}
    assert main(["compare", str(data), "--models", "linear", "poly3", "gpr", "--history", "0", "1", *CHEAP,
                 "--out", str(out)]) == 0  # fmt: skip
    rows = read_comparison(out)
    assert len(rows) == 3 * 2 * 5
    again = {(r["model"], r["history"], r["split"], r["split_index"]): r["test_rms_m"] for r in rows}
    assert all(again[k] == v for k, v in first.items())
