"""Fault-sweep rows (tests/sweep.py format) for ``--history K`` and the word forms of ``--split``
(``random``, ``group``) on ``train`` and ``splits``: bad K, K not below the longest sequence,
bad sequence starts, an inverse model with a past, bad words and ratios, an empty test set.

``seq.csv`` (made by :func:`seq`) is the sweep's ``data.csv`` (60 rows) with a sidecar of
a measured robot and the given ``sequence_starts``.
"""

from pathlib import Path

from sweep import Case

from lab.data import read_dataset, write_dataset

TRAIN = ["train", "{dir}/data.csv", "--hidden", "3", "--epochs", "3"]
SPLITS = ["splits", "{dir}/data.csv", "--hidden", "3", "--epochs", "3", "--n-splits", "2", "--jobs", "1"]
SEQ = ["train", "{dir}/seq.csv", "--hidden", "3", "--epochs", "3"]
M = ("--out", "{dir}/m.npz")
S = ("--out", "{dir}/s.csv")
DATA = ("{dir}/data.csv", "{dir}/data.csv.json")
SEQ_FILES = ("{dir}/seq.csv", "{dir}/seq.csv.json")
NO_M = ("{dir}/m.npz",)
NO_S = ("{dir}/s.csv",)


def seq(starts):
    """A setup writing ``seq.csv``: data.csv's rows, a measured robot, ``sequence_starts``."""

    def setup(d: Path):
        u, y, _ = read_dataset(d / "data.csv")
        robot = {"name": "toy", "kind": "measured", "n_motors": 3, "u_min": [0.0] * 3, "u_max": [1.0] * 3}
        write_dataset(d / "seq.csv", u, y, {"robot": robot, "sequence_starts": starts})

    return setup


HISTORY_CASES: list = [
    Case("history-negative", [*TRAIN, "--history", "-1", *M], 2, ("--history must be an integer >= 0",), DATA, NO_M),
    Case("history-huge", [*TRAIN, "--history", "1000000", *M], 2, ("--history must be at most 10",), DATA, NO_M),
    Case("splits-history-negative", [*SPLITS, "--history", "-3", *S], 2, ("--history must be",), DATA, NO_S),
    Case(
        "history-nan",
        [*TRAIN, "--history", "nan", *M],
        2,
        ("--history", "invalid int value: 'nan'"),
        DATA,
        NO_M,
        subprocess=True,
    ),
    Case(
        "history-inverse-mlp",
        [*TRAIN, "--model", "inverse-mlp", "--history", "1", *M],
        2,
        ("--history applies to forward models", "inverse-mlp"),
        DATA,
        NO_M,
    ),
    Case(
        "history-not-below-the-longest-sequence",
        [*SEQ, "--history", "6", *M],
        2,
        ("--history 6: the longest measurement sequence of {dir}/seq.csv has 6 rows", "sequence_starts"),
        SEQ_FILES,
        NO_M,
        setup=seq(list(range(0, 60, 6))),
    ),
    Case(
        "history-longer-than-one-sequence-of-data",
        ["splits", "{dir}/seq.csv", "--history", "10", "--jobs", "1", *S],
        2,
        ("the longest measurement sequence", "has 5 rows"),
        SEQ_FILES,
        NO_S,
        setup=seq(list(range(0, 60, 5))),
    ),
    Case(
        "history-bad-sequence-starts",
        [*SEQ, "--history", "1", *M],
        2,
        ("{dir}/seq.csv.json", "sequence_starts must be ascending row indices starting with 0"),
        SEQ_FILES,
        NO_M,
        setup=seq([0, 30, 10]),
    ),
    Case(
        "history-sequence-start-past-the-end",
        [*SEQ, "--split", "group", *M],
        2,
        ("sequence_starts", "below 60"),
        SEQ_FILES,
        NO_M,
        setup=seq([0, 20, 60]),
    ),
    Case(
        "history-init-without-history",
        [*TRAIN, "--history", "1", "--init", "{dir}/model.npz", *M],
        2,
        ("init maps 3 inputs", "the data have 6"),
        (*DATA, "{dir}/model.npz"),
        NO_M,
    ),
    Case("split-bogus", [*TRAIN, "--split", "bogus", *M], 2, ("--split must start with one of random, group",), DATA),
    Case("split-two-numbers", [*TRAIN, "--split", "0.8", "0.2", *M], 2, ("--split takes 3 ratios",), DATA, NO_M),
    Case("split-four-numbers", [*SPLITS, "--split", "0.7", "0.1", "0.1", "0.1", *S], 2, ("takes 3 ratios",), DATA),
    Case("split-group-two-numbers", [*TRAIN, "--split", "group", "0.9", "0.1", *M], 2, ("takes 3 ratios",), DATA),
    Case("split-ratios-then-word", [*TRAIN, "--split", "0.8", "0.1", "0.1", "group", *M], 2, ("3 ratios",), DATA),
    Case("split-group-not-a-number", [*TRAIN, "--split", "group", "a", "b", "c", *M], 2, ("'a' is not a number",)),
    Case(
        "split-group-no-training",
        [*TRAIN, "--split", "group", "0", "0.5", "0.5", *M],
        2,
        ("--split (ratios) must be 3 non-negative numbers", "train > 0"),
        DATA,
        NO_M,
    ),
    Case("split-group-nan", [*SPLITS, "--split", "group", "nan", "0", "1", *S], 2, ("non-negative numbers",), DATA),
    Case("split-group-inf", [*TRAIN, "--split", "group", "1", "0", "inf", *M], 2, ("non-negative numbers",), DATA),
    Case("split-group-negative", [*TRAIN, "--split", "group", "1", "-0.1", "0.1", *M], 2, ("non-negative",), DATA),
    Case(
        "split-group-empty-test-set",
        [*TRAIN, "--split", "group", "0.995", "0", "0.005", *M],
        2,
        ("too few to train on with split (0.995, 0.0, 0.005)", "one for each validation or test set"),
        DATA,
        NO_M,
    ),
    Case(
        "split-group-knn-empty-test-set",
        [*TRAIN, "--model", "knn", "--split", "group", "0.995", "0", "0.005", *M],
        2,
        ("too few to train on",),
        DATA,
        NO_M,
    ),
    Case(
        "splits-group-bogus-word",
        [*SPLITS, "--split", "groups", *S],
        2,
        ("--split must start with one of random, group", "'groups'"),
        DATA,
        NO_S,
    ),
]
