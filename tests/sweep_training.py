"""Fault-sweep rows (tests/sweep.py format) for the training algorithm's choice: ``--algorithm
auto`` (the default of ``train`` and ``splits``: LM or its sub-sampled form by size, said on the
first line) and ``--algorithm lm-subsample`` given, with a gradient stop it refuses."""

from pathlib import Path

import numpy as np
from sweep import Case


def large(d: Path):
    """``big.csv``: 2,800 rows of a smooth 3 -> 3 map, above LM's limit for 3-20-20-3 (80 % train)."""
    from lab.data import write_dataset

    rng = np.random.default_rng(0)
    u = rng.uniform(0, 2, (2800, 3))
    y = 0.05 * np.c_[np.sin(u[:, 0] + u[:, 1]), np.cos(u[:, 1] - u[:, 2]), u[:, 0] * u[:, 2] / 4]
    write_dataset(d / "big.csv", u, y, {})


TRAIN = ["train", "{dir}/data.csv", "--hidden", "3", "--epochs", "2", "--no-progress"]
SPLITS = ["splits", "{dir}/data.csv", "--hidden", "3", "--epochs", "2", "--n-splits", "2", "--jobs", "1",
          "--no-progress", "--out", "{dir}/s.csv"]  # fmt: skip

# fmt: off
TRAINING_CASES = [
    Case("train-algorithm-auto-small", [*TRAIN, "--out", "{dir}/m.npz"], 0,
         ("with lm (auto: ", "<= 2e+09)")),
    Case("train-algorithm-auto-large", ["train", "{dir}/big.csv", "--epochs", "1", "--no-progress",
                                        "--out", "{dir}/m.npz"], 0,
         ("with lm-subsample (auto: 6,720 residuals x 563^2 parameters", "> 2e+09)", "estimate: about"),
         setup=large),
    Case("train-algorithm-lm-subsample", [*TRAIN, "--algorithm", "lm-subsample", "--out", "{dir}/m.npz"], 0,
         ("(tanh) with lm-subsample, random split",)),
    Case("train-algorithm-lm-subsample-min-grad", [*TRAIN, "--algorithm", "lm-subsample", "--min-grad", "-1",
                                                   "--out", "{dir}/m.npz"], 2,
         ("--min-grad", ">= 0"), absent=("{dir}/m.npz",)),
    Case("splits-algorithm-auto", SPLITS, 0, ("network (lm, auto: ",)),
    Case("splits-algorithm-lm-subsample", [*SPLITS, "--algorithm", "lm-subsample"], 0,
         ("network (lm-subsample)",)),
]
# fmt: on
