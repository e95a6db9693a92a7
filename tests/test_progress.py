"""Long commands say how long: train, splits, compare, calibrate and inspect write one
estimate line after their first unit of work (epoch, split, fit, iteration, step) and draw a
tqdm bar on stderr, which --no-progress leaves out (the estimate line stays). No timing is
asserted: the words only, and the estimate's arithmetic on a clock the test drives."""

import io
import shutil
from pathlib import Path

import numpy as np
import pytest

from lab.cli import main
from lab.cli.progress import Progress, duration_words

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def data(tmp_path):
    """60 rows of the shipped simulated dataset, with its sidecar."""
    from lab.data import read_dataset, write_dataset

    u, y, meta = read_dataset(ROOT / "data" / "sim_three_cable.csv")
    path = tmp_path / "d.csv"
    write_dataset(path, u[::5][:60], y[::5][:60], {"robot": meta.get("robot")})
    return path


def bar_drawn(err: str, unit: str) -> bool:
    return f"{unit}/s]" in err


COMMANDS = {
    "epoch": lambda d, t: ["train", str(d), "--hidden", "3", "--epochs", "3", "--out", str(t / "m.npz")],
    "split": lambda d, t: [
        "splits",
        str(d),
        "--hidden",
        "3",
        "--epochs",
        "2",
        "--n-splits",
        "2",
        "--jobs",
        "1",
        "--out",
        str(t / "s.csv"),
    ],  # fmt: skip
    "fit": lambda d, t: [
        "compare",
        str(d),
        "--models",
        "linear",
        "poly3",
        "--n-splits",
        "1",
        "--history",
        "0",
        "--jobs",
        "1",
        "--out",
        str(t / "c.csv"),
    ],  # fmt: skip
    "step": lambda d, t: ["inspect", str(d), "--bootstrap", "5", "--out", str(t / "r.json")],
}


@pytest.mark.parametrize("unit", list(COMMANDS))
def test_an_estimate_after_the_first_unit_and_a_bar(unit, data, tmp_path, capsys):
    argv = COMMANDS[unit](data, tmp_path)
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "estimate: about " in err and f"(first {unit} " in err and f" {unit}s" in err, err
    assert bar_drawn(err, unit), err
    for p in tmp_path.iterdir():  # the same run again, into fresh outputs, without the bar
        if p.name != data.name and not p.name.startswith(data.name):
            shutil.rmtree(p) if p.is_dir() else p.unlink()
    assert main([*argv, "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "estimate: about " in err and not bar_drawn(err, unit), err


def test_calibrate_estimates_from_its_first_iteration(data, tmp_path, capsys):
    argv = ["calibrate", str(data), "--out", str(tmp_path / "c.toml"), "--n-rings", "1", "--n-axial", "6"]
    for extra, bar in (([], True), (["--no-progress"], False)):
        assert main([*argv, "--max-iter", "1", *extra]) == 1  # one iteration does not converge: exit 1
        err = capsys.readouterr().err
        assert "estimate: about " in err and "less if it stops early (first iteration " in err, err
        assert "x 1 iterations" in err and bar_drawn(err, "iteration") == bar, err


def test_the_estimate_is_the_first_unit_times_the_rounds():
    now = [0.0]
    out = io.StringIO()
    p = Progress("split", enabled=False, parallel=4, file=out, clock=lambda: now[0])
    p.update(0, 10)
    now[0] = 20.0
    p.update(1, 10)  # 20 s for the first; 10 splits on 4 workers: 3 rounds
    assert p.estimate_s == pytest.approx(60.0)
    assert out.getvalue() == "estimate: about 60 s in all (first split 20 s x 10 splits / 4 workers)\n"
    now[0] = 200.0
    p.update(5, 10)  # said once
    assert out.getvalue().count("estimate") == 1
    assert [duration_words(s) for s in (0.6, 42, 420, 9000)] == ["0.6 s", "42 s", "7 min", "2.5 h"]


def test_train_counts_the_epochs_its_algorithm_allows(data, tmp_path, capsys):
    """Without --epochs the bar's total is the algorithm's own limit (Adam's 1000 here)."""
    from lab.learn.train import max_epochs

    assert max_epochs("lm") == 1000 and max_epochs("adam", 7) == 7
    seen = []
    from lab.jobs.train import run
    from lab.learn.train_spec import TrainSpec

    run(TrainSpec(hidden=(3,), epochs=4), data, progress=lambda done, total: seen.append((done, total)))
    assert seen[0] == (0, 4) and all(t == 4 for _, t in seen) and np.all(np.diff([d for d, _ in seen]) == 1)


@pytest.mark.parametrize(
    "kind, words",
    [
        (["--model", "ensemble", "--members", "2", "--jobs", "1"], "x 6 epochs)"),  # 2 members x 3 epochs
        (["--model", "ensemble", "--members", "3", "--jobs", "2"], "x 9 epochs)"),  # the workers' epochs together
        (["--model", "inverse-mlp"], "x 3 epochs)"),
    ],
)
def test_ensembles_and_the_inverse_say_how_long_too(kind, words, data, tmp_path, capsys):
    """The README's recipe for a lab's own data trains an ensemble: it says how long as the
    plain network does (every member's epochs; on several workers, theirs together as they go)."""
    assert main(["train", str(data), "--hidden", "3", "--epochs", "3", *kind, "--out", str(tmp_path / "m.npz")]) == 0
    err = capsys.readouterr().err
    assert "estimate: about " in err and words in err, err
    assert bar_drawn(err, "epoch"), err


def test_an_ensembles_members_do_not_depend_on_progress(data):
    from lab.data import read_dataset
    from lab.learn.ensemble import train_ensemble

    u, y, _ = read_dataset(data)
    seen = []
    a = train_ensemble(u, y, (3,), k=2, epochs=3, progress=lambda d, t: seen.append((d, t)))
    b = train_ensemble(u, y, (3,), k=2, epochs=3)
    assert seen[-1] == (6, 6) and all(t == 6 for _, t in seen) and [d for d, _ in seen] == sorted(d for d, _ in seen)
    for ma, mb in zip(a.members, b.members):
        assert all(np.array_equal(wa, wb) for wa, wb in zip(ma.weights, mb.weights))
