"""Fault-sweep rows (tests/sweep.py format) for the time estimate and bar of long commands
(``--no-progress`` on train, splits, compare, calibrate and inspect), group splits of
unequal sequences, and compare's floor reports (told by content hash) and history rule.

The setups write datasets the sweep's ``data.csv`` (60 FEM samples, one sequence) is not:
measured data whose sequences are unequal (``seq.csv``), and a CSV without a sidecar with
its ``inspect`` report (``a/p.csv``, ``a/r.json``).
"""

import csv
import json
import shutil
from pathlib import Path

from sweep import Case
from test_compare_floor import plain_csv
from test_group_split_balance import unequal_dataset

TRAIN = ["train", "{dir}/data.csv", "--hidden", "3", "--epochs", "2", "--no-progress", "--out", "{dir}/m.npz"]
SPLITS = ["splits", "{dir}/data.csv", "--hidden", "3", "--epochs", "2", "--n-splits", "2", "--jobs", "1",
          "--no-progress", "--out", "{dir}/s.csv"]  # fmt: skip
COMPARE = ["compare", "--models", "linear", "--n-splits", "1", "--history", "0", "--jobs", "1", "--no-progress"]
KEEP = ("{dir}/data.csv", "{dir}/data.csv.json")


def sequences(*lengths: int):
    """A setup writing ``seq.csv``: measured data whose sequences have these lengths."""

    def setup(d: Path):
        unequal_dataset(d / "seq.csv", list(lengths))

    return setup


def inspected(d: Path):
    """``a/p.csv`` (no sidecar) and its inspect report ``a/r.json``."""
    from lab.cli import main

    plain_csv(d / "a" / "p.csv")
    assert (
        main(["inspect", str(d / "a" / "p.csv"), "--bootstrap", "5", "--no-progress", "--out", str(d / "a" / "r.json")])
        == 0
    )


def stale(d: Path):
    """The report of ``a/p.csv``, then the file changed."""
    inspected(d)
    plain_csv(d / "a" / "p.csv", shift_m=0.01)


def moved(d: Path):
    """The report of ``a/p.csv`` and the same bytes in ``b/p.csv``."""
    inspected(d)
    (d / "b").mkdir()
    shutil.copy(d / "a" / "p.csv", d / "b" / "p.csv")


def _trained_on(n: int, splits: int):
    def after(d: Path):
        assert [int(r["train_n"]) for r in csv.DictReader((d / "s.csv").open())] == [n] * splits

    return after


def _trained_200(d: Path):
    assert json.loads((d / "r.json").read_text())["train"]["n"] == 200


def _floor_kept(d: Path):
    assert json.loads((d / "c.csv.json").read_text())["floor"]["floor_m"] > 0


def _warned_in_report(d: Path):
    assert "trains on 60 of 180 rows" in json.loads((d / "r.json").read_text())["split_warning"]


# fmt: off
PROGRESS_CASES = [
    Case("progress-train-no-progress", TRAIN, 0, ("estimate: about", "(first epoch", "x 2 epochs"), KEEP),
    Case("progress-splits-no-progress", SPLITS, 0, ("estimate: about", "(first split", "x 2 splits"), KEEP),
    Case("progress-compare-no-progress", [*COMPARE, "{dir}/data.csv", "--out", "{dir}/c.csv"], 0,
         ("estimate: about", "(first fit"), KEEP),
    Case("progress-inspect-no-progress", ["inspect", "{dir}/data.csv", "--bootstrap", "5", "--no-progress", "--out",
                                          "{dir}/r.json"], 0, ("estimate: about", "(first step"), KEEP),
    Case("progress-calibrate-no-progress", ["calibrate", "{dir}/data.csv", "--no-progress", "--noise-m", "-1",
                                            "--out", "{dir}/c.toml"], 2, ("--noise-m",), KEEP, ("{dir}/c.toml",)),
    Case("group-split-unequal-sequences-splits", ["splits", "{dir}/seq.csv", "--hidden", "3", "--epochs", "2",
                                                  "--n-splits", "5", "--jobs", "1", "--split", "group",
                                                  "--no-progress", "--out", "{dir}/s.csv"], 0,
         setup=sequences(200, 5, 5), after=_trained_on(200, 5)),
    Case("group-split-unequal-sequences-train", ["train", "{dir}/seq.csv", "--hidden", "3", "--epochs", "2",
                                                 "--split", "group", "--no-progress", "--out", "{dir}/m.npz",
                                                 "--report", "{dir}/r.json"], 0,
         setup=sequences(200, 5, 5),
         after=_trained_200),
    Case("group-split-sliver-warned", ["train", "{dir}/seq.csv", "--hidden", "3", "--epochs", "2", "--split", "group",
                                       "--no-progress", "--out", "{dir}/m.npz", "--report", "{dir}/r.json"], 0,
         ("warning: the group split trains on 60 of 180 rows",), setup=sequences(60, 60, 60),
         after=_warned_in_report),
    Case("compare-floor-stale-report", [*COMPARE, "{dir}/a/p.csv", "--floor", "{dir}/a/r.json", "--out",
                                        "{dir}/c.csv"], 2, ("another dataset than", "or the file changed since"),
         absent=("{dir}/c.csv", "{dir}/c.csv.json"), setup=stale),
    Case("compare-floor-same-data-other-folder", [*COMPARE, "{dir}/b/p.csv", "--floor", "{dir}/a/r.json", "--out",
                                                 "{dir}/c.csv"], 0, setup=moved, after=_floor_kept),
    Case("compare-history-not-below-the-longest-sequence",
         ["compare", "{dir}/seq.csv", "--models", "linear", "--history", "6", "--jobs", "1", "--out", "{dir}/c.csv"],
         2, ("--history 6: the longest measurement sequence", "K must be below it"),
         absent=("{dir}/c.csv", "{dir}/c.csv.json"), setup=sequences(6, 6, 6, 6, 6)),
]
# fmt: on
