"""--split group: whole measurement sequences on one side of the split (lab.learn.split),
the word forms of --split on train and splits, and the contiguous blocks of one sequence."""

import csv
import json

import numpy as np
import pytest
from test_history import measured_dataset

from lab.cli import main
from lab.errors import InputError
from lab.learn import load_model
from lab.learn.split import N_BLOCKS, divide, divide_groups, split_groups
from lab.learn.train_spec import TrainSpec


def groups_of(sizes):
    return np.repeat(np.arange(len(sizes)), sizes)


def test_divide_groups_keeps_groups_whole_near_the_ratios_and_is_seeded():
    rng = np.random.default_rng(0)
    sizes = rng.integers(5, 30, 40)
    g = groups_of(sizes)
    n = len(g)
    for seed in range(5):
        s = divide_groups(g, (0.7, 0.15, 0.15), seed)
        parts = [s.train, s.validation, s.test]
        assert sorted(np.concatenate(parts).tolist()) == list(range(n))  # a partition of the rows
        owner = {}
        for name, idx in zip("tvs", parts):
            for grp in np.unique(g[idx]):
                assert owner.setdefault(grp, name) == name  # no group on two sides
        # the row counts approach the ratios: within one group's size (< 30 rows)
        assert abs(len(s.test) - 0.15 * n) < 30 and abs(len(s.validation) - 0.15 * n) < 30
    a, b, c = (divide_groups(g, (0.8, 0.1, 0.1), seed) for seed in (3, 3, 4))
    np.testing.assert_array_equal(a.test, b.test)
    assert not np.array_equal(a.test, c.test)
    # a set of ratio 0 stays empty; a set asked for gets a group even when its share is small
    assert len(divide_groups(g, (0.9, 0.0, 0.1), 0).validation) == 0
    s = divide_groups(groups_of([50, 50, 50]), (0.98, 0.01, 0.01), 0)
    assert [len(s.train), len(s.validation), len(s.test)] == [50, 50, 50]
    with pytest.raises(InputError, match="needs at least 3 sequences"):
        divide_groups(groups_of([5, 5]), (0.8, 0.1, 0.1))
    with pytest.raises(InputError, match="split ratios"):
        divide_groups(g, (0.0, 0.5, 0.5))
    with pytest.raises(InputError, match="one group per row"):
        divide(n + 1, (0.8, 0.1, 0.1), 0, g)


def test_fewer_than_three_sequences_become_contiguous_blocks():
    groups, what = split_groups(np.array([0] * 37 + [1] * 13))
    assert what == "contiguous_blocks" and len(np.unique(groups)) == N_BLOCKS
    assert np.all(np.diff(groups) >= 0)  # blocks in measurement order
    ids = groups_of([4, 4, 4])
    assert split_groups(ids)[1] == "sequences" and split_groups(ids)[0] is ids


def test_split_words_on_the_spec():
    assert (TrainSpec(ratios=("group",)).split, TrainSpec(ratios=("group",)).ratios) == ("group", (0.8, 0.1, 0.1))
    spec = TrainSpec(ratios=("GROUP", "0.6", "0.2", "0.2"))
    assert (spec.split, spec.ratios) == ("group", (0.6, 0.2, 0.2))
    assert spec.replace(seed=3).split == "group"  # replace keeps the parsed split
    assert TrainSpec(ratios=("random", "1", "0", "0")).split == "random"
    assert TrainSpec(split="group").ratios == (0.8, 0.1, 0.1)
    for bad, words in (
        (("bogus",), "TrainSpec.ratios must start with one of random, group"),
        (("0.8", "0.2"), "TrainSpec.ratios takes 3 ratios"),
        (("group", "0.8", "0.2"), "TrainSpec.ratios takes 3 ratios"),
        (("group", "x", "0.1", "0.1"), "TrainSpec.ratios ratio 'x' is not a number"),
        (("group", "nan", "0.1", "0.1"), "must be 3 non-negative numbers"),
        (("random", "0.8", "-0.1", "0.3"), "must be 3 non-negative numbers"),
    ):
        with pytest.raises(InputError, match=words):
            TrainSpec(ratios=bad)


def test_train_group_split_holds_out_whole_sequences(tmp_path, capsys):
    data = tmp_path / "trunk.csv"
    measured_dataset(data, n_seq=8, length=10)
    out, rep = tmp_path / "m.npz", tmp_path / "r.json"
    argv = ["train", str(data), "--hidden", "4", "--epochs", "5", "--split", "group", "0.6", "0.2", "0.2"]
    assert main([*argv, "--out", str(out), "--report", str(rep)]) == 0
    report = json.loads(rep.read_text())
    assert report["split"] == [0.6, 0.2, 0.2]  # an existing key, unchanged
    assert (report["split_method"], report["split_groups"], report["n_groups"]) == ("group", "sequences", 8)
    split = load_model(out).metadata["training"]["split"]
    assert split["method"] == "group"
    seq = np.arange(80) // 10
    sides = [set(seq[split["indices"][name]]) for name in ("train", "validation", "test")]
    assert not (sides[0] & sides[1] or sides[0] & sides[2] or sides[1] & sides[2])
    assert [len(s) for s in sides] == [4, 2, 2]  # 20 rows (2 sequences) nearest 0.2 of 80
    # --split random and no word are the same split (dividerand), as before
    r2 = tmp_path / "r2.json"
    assert main(["train", str(data), "--hidden", "4", "--epochs", "5", "--split", "random", "--out",
                 str(tmp_path / "m2.npz"), "--report", str(r2)]) == 0  # fmt: skip
    assert json.loads(r2.read_text())["split_method"] == "random"
    assert json.loads(r2.read_text())["split_groups"] is None


def test_one_sequence_is_cut_into_blocks_with_a_note(tmp_path, capsys):
    data = tmp_path / "one.csv"
    measured_dataset(data, n_seq=1, length=60, starts=False)
    out, rep = tmp_path / "m.npz", tmp_path / "r.json"
    argv = ["train", str(data), "--hidden", "4", "--epochs", "5", "--split", "group"]
    assert main([*argv, "--out", str(out), "--report", str(rep)]) == 0
    assert "cuts the rows into 10 contiguous blocks in measurement order" in capsys.readouterr().err
    report = json.loads(rep.read_text())
    assert (report["split_groups"], report["n_groups"]) == ("contiguous_blocks", 10)
    test = np.array(load_model(out).metadata["training"]["split"]["indices"]["test"])
    assert len(test) == 6 and np.all(np.diff(test) == 1)  # one block of 6 consecutive rows


def test_splits_group_keeps_its_own_ratios_and_writes_the_kind(tmp_path, capsys):
    data = tmp_path / "trunk.csv"
    measured_dataset(data, n_seq=10, length=6)
    out = tmp_path / "s.csv"
    argv = ["splits", str(data), "--hidden", "4", "--epochs", "5", "--n-splits", "3", "--jobs", "1"]
    assert main([*argv, "--split", "group", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert {r["split_method"] for r in rows} == {"group"} and rows[0]["split_groups"] == "sequences"
    assert all(r["validation_n"] == "0" and r["test_n"] == "6" for r in rows)  # 90/0/10 of 10 sequences
    assert len({r["seed"] for r in rows}) == 3
    assert main([*argv, "--model", "knn", "--split", "group", "0.8", "0.1", "0.1", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert all(r["validation_n"] == "6" and r["test_n"] == "6" and r["model"] == "knn" for r in rows)
