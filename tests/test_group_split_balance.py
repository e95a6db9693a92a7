"""Group splits of unequal sequences: a long sequence stays in training rather than being
held out whole and leaving training a sliver, and a split that cannot help being a sliver
says so in the summary and the report."""

import csv
import json

import numpy as np
from test_history import measured_dataset

from lab.cli import main
from lab.learn.split import divide, thin_training_note
from lab.learn.studies import run_seeds


def unequal_dataset(path, lengths):
    """A measured dataset whose sequences have the given lengths (sidecar sequence_starts)."""
    from lab.data import read_dataset, write_dataset

    measured_dataset(path, n_seq=1, length=sum(lengths))
    u, y, meta = read_dataset(path)
    meta["sequence_starts"] = [int(s) for s in np.cumsum([0, *lengths[:-1]])]
    path.unlink()
    path.with_name(path.name + ".json").unlink()
    write_dataset(path, u, y, {k: v for k, v in meta.items() if k != "csv_sha256"})


def test_a_long_sequence_stays_in_training():
    g = np.repeat([0, 1, 2], [200, 5, 5])  # sequence_starts [0, 200, 205] of 210 rows
    for ratios, seeds in (((0.8, 0.1, 0.1), range(8)), ((0.9, 0.0, 0.1), run_seeds(0, 5))):
        trained = [len(divide(210, ratios, np.random.default_rng(s), g).train) for s in seeds]
        assert trained == [200] * len(trained), (ratios, trained)  # was 5 or 10 rows for most seeds


def test_train_and_splits_on_unequal_sequences_train_on_the_long_one(tmp_path, capsys):
    data = tmp_path / "d.csv"
    unequal_dataset(data, [200, 5, 5])
    rep = tmp_path / "r.json"
    argv = ["train", str(data), "--hidden", "3", "--epochs", "2", "--split", "group", "--no-progress"]
    assert main([*argv, "--out", str(tmp_path / "m.npz"), "--report", str(rep)]) == 0
    report = json.loads(rep.read_text())
    assert report["train"]["n"] == 200 and report["split_warning"] is None
    out = tmp_path / "s.csv"
    argv = ["splits", str(data), "--hidden", "3", "--epochs", "2", "--n-splits", "5", "--jobs", "1", "--no-progress"]
    assert main([*argv, "--split", "group", "--out", str(out)]) == 0
    assert [int(r["train_n"]) for r in csv.DictReader(out.open())] == [200] * 5
    assert "warning" not in capsys.readouterr().out


def test_a_sliver_that_cannot_be_helped_is_warned_about(tmp_path, capsys):
    assert thin_training_note(144, 180, (0.8, 0.1, 0.1)) is None
    note = thin_training_note(60, 180, (0.8, 0.1, 0.1))
    assert "trains on 60 of 180 rows" in note and "144" in note
    data = tmp_path / "d.csv"
    unequal_dataset(data, [60, 60, 60])  # three equal sequences: one each for train, validation, test
    rep = tmp_path / "r.json"
    argv = ["train", str(data), "--hidden", "3", "--epochs", "2", "--split", "group", "--no-progress"]
    assert main([*argv, "--out", str(tmp_path / "m.npz"), "--report", str(rep)]) == 0
    captured = capsys.readouterr()
    assert "warning: the group split trains on 60 of 180 rows" in captured.out
    assert "trains on 60 of 180 rows" in json.loads(rep.read_text())["split_warning"]
    out = tmp_path / "s.csv"
    argv = ["splits", str(data), "--hidden", "3", "--epochs", "2", "--n-splits", "2", "--jobs", "1", "--no-progress"]
    assert main([*argv, "--split", "group", "0.8", "0.1", "0.1", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "warning: split 0: the group split trains on 60 of 180 rows" in captured.out
