"""``simulate`` and ``capture`` with ``--active N --batch B`` (and the other sampling flags), end to end."""

import json

import numpy as np
import pytest

from lab.cli import main
from lab.data import design_commands, read_dataset, sobol_commands
from lab.description import ROBOTS_DIR, load_robot

ENSEMBLE = ["--ensemble-members", "2", "--ensemble-hidden", "4", "--ensemble-epochs", "3"]
SIM = ["simulate", "--n-rings", "1", "--n-axial", "4", "--jobs", "1", "--no-progress"]


def _no_fit_s(log):
    return [{k: v for k, v in e.items() if k != "fit_s"} for e in log]


class Kill:
    """Replace ``obj.name`` by a wrapper that raises KeyboardInterrupt at its ``at``-th call."""

    def __init__(self, monkeypatch, obj, name, at):
        self.calls, original = 0, getattr(obj, name)

        def wrapper(*args, **kwargs):
            self.calls += 1
            if self.calls == at:
                raise KeyboardInterrupt
            return original(*args, **kwargs)

        monkeypatch.setattr(obj, name, wrapper)


def test_simulate_active_resumes_after_a_kill(tmp_path, monkeypatch, capsys):
    import lab.data.simulation

    args = [*SIM, "--active", "20", "--batch", "6", *ENSEMBLE, "--seed", "2"]
    assert main([*args, "--out", str(tmp_path / "full.csv")]) == 0
    u, y, meta = read_dataset(tmp_path / "full.csv")
    robot = load_robot("three-cable")
    assert u.shape == (20, 3) and np.all(robot.is_safe(u)) and np.all(np.isfinite(y))
    s = meta["sampler"]
    assert (s["name"], s["n"], s["batch"], s["seed"], s["n_initial"], s["n_batches"]) == ("active", 20, 6, 2, 10, 3)
    assert s["ensemble"] == {"trainer": "lab.learn.ensemble.train_ensemble", "members": 2, "hidden": [4], "epochs": 3}
    assert [(e["batch"], e["kind"], e["n"]) for e in s["log"]] == [
        (0, "initial", 10),
        (1, "active", 6),
        (2, "active", 4),
    ]
    assert all(e["picked_spread_mean_m"] >= e["pool_spread_mean_m"] for e in s["log"][1:])
    assert np.array_equal(u[:10], sobol_commands(robot, 10, seed=2))  # the initial design first
    assert not (tmp_path / "full.csv.chunks").exists()  # the checkpoint is removed once written

    out, chunks = tmp_path / "killed.csv", tmp_path / "killed.csv.chunks"
    Kill(monkeypatch, lab.data.simulation, "simulate", at=3)  # killed while solving batch 2
    assert main([*args, "--out", str(out)]) == 130
    assert not out.exists() and sorted(p.name for p in chunks.glob("chunk_*")) == ["chunk_00000.npz", "chunk_00001.npz"]
    monkeypatch.undo()
    capsys.readouterr()
    assert main([*args, "--out", str(out)]) == 0
    assert "resumed: 16 samples" in capsys.readouterr().err
    u2, y2, meta2 = read_dataset(out)
    assert np.array_equal(u2, u) and np.abs(y2 - y).max() < 1e-9
    assert _no_fit_s(meta2["sampler"]["log"]) == _no_fit_s(s["log"])
    assert meta2["solver"]["resumed_samples"] == 16
    # a checkpoint of other settings is refused, not mixed in
    Kill(monkeypatch, lab.data.simulation, "simulate", at=2)
    assert main([*args, "--out", str(out)]) == 130
    monkeypatch.undo()
    assert main([*SIM, "--active", "20", "--batch", "5", *ENSEMBLE, "--seed", "2", "--out", str(out)]) == 2
    assert "belongs to another run" in capsys.readouterr().err


def test_simulate_lhs_and_design(tmp_path):
    robot = load_robot("three-cable")
    assert main([*SIM, "--lhs", "6", "--seed", "1", "--out", str(tmp_path / "l.csv")]) == 0
    u, _, meta = read_dataset(tmp_path / "l.csv")
    assert np.array_equal(u, design_commands(robot, 6, "lhs", seed=1))
    assert meta["sampler"]["name"] == "lhs" and meta["sampler"]["n"] == 6 and meta["sampler"]["n_safe"] == 6
    assert main([*SIM, "--design", "maximin", "--n", "5", "--out", str(tmp_path / "m.csv")]) == 0
    u, _, meta = read_dataset(tmp_path / "m.csv")
    assert np.array_equal(u, design_commands(robot, 5, "maximin", seed=0)) and meta["sampler"]["name"] == "maximin"


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--active", "10"], "needs the batch size"),
        (["--batch", "3"], "--batch B goes with --active"),
        (["--active", "10", "--batch", "0"], "at least 1"),
        (["--active", "10", "--batch", "3", "--ensemble-members", "1"], "--ensemble-members"),
        (["--active", "10", "--batch", "3", "--ensemble-hidden", "0"], "--ensemble-hidden"),
        (["--active", "10", "--batch", "3", "--ensemble-epochs", "0"], "--ensemble-epochs"),
        (["--lhs", "0"], "--lhs must be at least 1"),
        (["--sobol", "5", "--n", "5"], "--n N goes with --design"),
        (["--n", "5"], "--n N goes with --design"),
        (["--design", "lhs"], "needs the number of commands"),
    ],
)
def test_bad_sampling_flags(argv, words, tmp_path, capsys):
    for command in (SIM, ["capture", "--no-progress"]):
        out = tmp_path / "o.csv"
        assert main([*command, *argv, "--out", str(out)]) == 2
        assert words in capsys.readouterr().err
        assert not out.exists() and not list(tmp_path.iterdir())


def _coarse_robot(d):
    text = (ROBOTS_DIR / "three-cable.toml").read_text()
    (d / "coarse.toml").write_text(text.replace("n_rings = 3", "n_rings = 1").replace("n_axial = 20", "n_axial = 4"))
    return d / "coarse.toml"


def test_capture_active_finishes_the_batch_it_was_killed_in(tmp_path, monkeypatch, capsys):
    from lab.rig.sim import SimRig

    robot = _coarse_robot(tmp_path)
    args = ["capture", "--rig", "sim", "--robot", str(robot), "--active", "14", "--batch", "4", *ENSEMBLE]
    args += ["--no-progress", "--seed", "1"]
    assert main([*args, "--out", str(tmp_path / "full.csv")]) == 0
    u, y, meta = read_dataset(tmp_path / "full.csv")
    s = meta["sampler"]
    assert u.shape == (14, 3) and s["name"] == "active" and s["n_initial"] == 7
    assert [(e["batch"], e["n"]) for e in s["log"]] == [(0, 7), (1, 4), (2, 3)]
    assert "--active 14 --batch 4 --ensemble-members 2" in meta["command"]

    # each sample sends 3 commands (reset up, release, command): send 30 is inside sample 10, batch 1
    Kill(monkeypatch, SimRig, "_send", at=30)
    out = tmp_path / "killed.csv"
    assert main([*args, "--out", str(out)]) == 130
    journal = tmp_path / "killed.journal.csv"
    assert sum(line[:1].isdigit() for line in journal.read_text().splitlines()) == 9
    assert not (tmp_path / "killed.journal.csv.lock").exists()  # killed, it still let go of the journal
    monkeypatch.undo()
    capsys.readouterr()
    assert main([*args, "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "finishing batch 1 as planned" in err and "(5 new)" in err
    u2, y2, meta2 = read_dataset(out)
    assert np.array_equal(u2, u) and np.abs(y2 - y).max() < 1e-6
    # the batch re-measured after the kill differs from the first run's by the solver's tolerance
    for a, b in zip(meta2["sampler"]["log"], s["log"], strict=True):
        assert a.keys() == b.keys()
        for k in a:
            if k.endswith("_m"):
                assert a[k] == pytest.approx(b[k], rel=1e-6)
            elif k != "fit_s":
                assert a[k] == b[k]
    assert main([*args, "--out", str(out)]) == 0 and "(0 new)" in capsys.readouterr().err  # complete
    # the journal refuses other settings
    assert main([*args[:-2], "--seed", "2", "--out", str(out)]) == 2
    assert "sampler.seed" in capsys.readouterr().err
    header = json.loads(journal.read_text().split("\n")[0][len("# lab.journal 1 ") :])
    assert header["commands"] == {"open_ended": True}


def test_capture_lhs(tmp_path):
    robot = _coarse_robot(tmp_path)
    out = tmp_path / "l.csv"
    assert (
        main(["capture", "--rig", "sim", "--robot", str(robot), "--lhs", "3", "--no-progress", "--out", str(out)]) == 0
    )
    u, _, meta = read_dataset(out)
    assert np.array_equal(u, design_commands(load_robot(robot), 3, "lhs", seed=0))
    assert meta["sampler"]["name"] == "lhs" and "--design lhs --n 3" in meta["command"]


def test_batch_store_round_trip_and_a_corrupt_batch(tmp_path):
    from lab.data.batchstore import BatchStore
    from lab.data.chunkstore import CheckpointError

    fp = {"kind": "lab.active-checkpoint", "n": 9}
    store = BatchStore(tmp_path / "ck", fp)
    rng = np.random.default_rng(0)
    for i in range(3):
        u = rng.random((3, 3))
        res = {"order": np.arange(3), "u_motor": u, "p_tip_W": u[:, ::-1], "iterations": np.ones(3, int)}
        store.save_batch(i, {**res, "factorizations": np.ones(3, int), "time_s": np.zeros(3)}, {"batch": i, "x": 0.5})
    batches = BatchStore(tmp_path / "ck", fp).load_batches()
    assert [b["entry"] for b in batches] == [{"batch": i, "x": 0.5} for i in range(3)]
    assert np.array_equal(batches[2]["p_tip_W"], batches[2]["u_motor"][:, ::-1])
    (tmp_path / "ck" / "chunk_00001.npz").write_bytes(b"torn")  # killed while writing? never (atomic), but a bad disk
    assert len(BatchStore(tmp_path / "ck", fp).load_batches()) == 1
    assert sorted(p.name for p in (tmp_path / "ck").glob("chunk_*")) == ["chunk_00000.npz"]  # later ones re-measured
    with pytest.raises(CheckpointError, match="belongs to another run"):
        BatchStore(tmp_path / "ck", {**fp, "n": 10})


def test_design_spec_reads_and_reproduces_the_flags():
    from lab.data import DesignSpec
    from lab.errors import InputError

    robot = load_robot("three-cable")
    assert (DesignSpec().kind, DesignSpec().levels, DesignSpec().words()) == ("grid", 7, ["--grid", "7"])
    s = DesignSpec(sobol=8, seed=3)
    assert (s.kind, s.method, s.n_commands, s.words()) == ("design", "sobol", 8, ["--design", "sobol", "--n", "8"])
    u, meta = s.commands(robot)
    assert np.array_equal(u, design_commands(robot, 8, "sobol", seed=3)) and meta["name"] == "sobol"
    a = DesignSpec(active=20, batch=5, ensemble_hidden=[4, 4])
    assert (
        a.ensemble_hidden == (4, 4)
        and " ".join(a.words()) == "--active 20 --batch 5 --ensemble-members 5 --ensemble-hidden 4 4"
    )
    for kwargs, words in [
        (dict(grid=3, sobol=4), "are different designs"),
        (dict(lhs=200_000), "at most 100000"),
        (dict(active=10**6, batch=5), "DesignSpec.active must be at most"),
        (dict(active=100, batch=5000), "DesignSpec.batch must be at most 4096"),
        (dict(seed=-1), "DesignSpec.seed must be an integer >= 0"),
    ]:
        with pytest.raises(InputError, match=words):
            DesignSpec(**kwargs)
    with pytest.raises(InputError, match="at most 4,194,304"):
        DesignSpec(grid=2000).check(robot)
    with pytest.raises(InputError, match="no fixed commands"):
        a.commands(robot)


def test_an_active_budget_must_fit_the_first_ensemble():
    from lab.data import DesignSpec
    from lab.errors import InputError
    from lab.learn.active_design import check_active

    for name, ok, bad in (("three-cable", 12, 11), ("six-cable", 16, 15)):
        robot = load_robot(name)
        check_active(DesignSpec(active=ok, batch=2), robot)
        with pytest.raises(InputError, match=f"use DesignSpec.active {ok} or more"):
            check_active(DesignSpec(active=bad, batch=2), robot)
    check_active(DesignSpec(active=1, batch=1), load_robot("three-cable"))  # the initial design is all of it
