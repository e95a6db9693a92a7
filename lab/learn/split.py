"""Dividing a dataset into training, validation and test sets, and how much data that needs.

Splits follow MATLAB ``dividerand``: a random permutation, ``round(ratio * N)`` samples
for validation and test, the rest for training (:func:`divide_random`).
:func:`check_enough_data` refuses data too small for a split -- one row, identical rows,
fewer distinct commands than a fit needs -- with the minimum in the message, before any
training starts (a degenerate model would otherwise be written with exit code 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError


@dataclass
class Split:
    """Sample indices of the training, validation and test sets (sorted, disjoint)."""

    train: np.ndarray
    validation: np.ndarray
    test: np.ndarray

    def sizes(self) -> dict:
        return {"train": len(self.train), "validation": len(self.validation), "test": len(self.test)}


def divide_random(n: int, ratios=(0.7, 0.15, 0.15), seed: int | np.random.Generator = 0) -> Split:
    """MATLAB ``dividerand``: ratios (train, validation, test) are normalised by their sum;
    validation and test get ``round(ratio * n)`` samples, training the rest."""
    r = np.asarray(ratios, dtype=float)
    if r.shape != (3,) or np.any(r < 0) or not np.all(np.isfinite(r)) or r[0] <= 0:
        raise InputError(
            f"split ratios must be 3 non-negative numbers (train, validation, test) with train > 0, got {tuple(ratios)}"
        )
    r = r / r.sum()
    n_val, n_test = int(round(r[1] * n)), int(round(r[2] * n))
    n_train = n - n_val - n_test
    if n_train < 1:
        raise InputError(f"split {tuple(ratios)} of {n} samples leaves no training samples")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    perm = rng.permutation(n)
    return Split(np.sort(perm[:n_train]), np.sort(perm[n_train : n_train + n_val]), np.sort(perm[n_train + n_val :]))


def _sizes(n: int, ratios) -> tuple[int, int, int]:
    r = np.asarray(ratios, dtype=float)
    r = r / r.sum()
    n_val, n_test = int(round(r[1] * n)), int(round(r[2] * n))
    return n - n_val - n_test, n_val, n_test


def minimum_samples(n_inputs: int, ratios) -> int:
    """The fewest samples a split ``ratios`` of an ``n_inputs``-input dataset may have: the
    training set needs ``n_inputs + 1`` samples (an affine map is the least a network must
    fit) and every set the ratios ask for needs at least one."""
    r = np.asarray(ratios, dtype=float)
    for n in range(1, 100_000):
        n_train, n_val, n_test = _sizes(n, r)
        if n_train >= n_inputs + 1 and (n_val >= 1 or r[1] == 0) and (n_test >= 1 or r[2] == 0):
            return n
    raise InputError(f"split ratios {tuple(ratios)} never give usable sets")


def check_enough_data(u: np.ndarray, ratios) -> None:
    """Raise InputError unless the commands ``u`` (N, n_u) can be split by ``ratios`` into
    usable sets: at least :func:`minimum_samples` samples and as many *distinct* commands."""
    u = np.asarray(u, dtype=float)
    divide_random(max(len(u), 1), ratios)  # validates the ratios themselves
    need = minimum_samples(u.shape[1], ratios)
    distinct = len(np.unique(u, axis=0)) if len(u) else 0
    if len(u) < need or distinct < need:
        what = f"{len(u)} samples" + (f" ({distinct} distinct commands)" if distinct < len(u) else "")
        raise InputError(
            f"{what} are too few to train on with split {tuple(float(x) for x in ratios)}: "
            f"need at least {need} samples with distinct commands ({u.shape[1] + 1} to train on, "
            "one for each validation or test set asked for)"
        )
