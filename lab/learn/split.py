"""Dividing a dataset into training, validation and test sets, and how much data that needs.

Splits follow MATLAB ``dividerand``: a random permutation, ``round(ratio * N)`` samples
for validation and test, the rest for training (:func:`divide_random`). A *group* split
(:func:`divide_groups`, ``--split group``) holds out whole measurement sequences instead,
so that no row measured just before or after a test row is trained on (rows of one
sequence are strongly correlated; a random split then flatters the model): sequences are
dealt out in seeded random order so that the row counts approach the ratios (a sequence
longer than twice a held-out set's share stays in training), :func:`thin_training_note`
warns of a training set under half its share (sequences too unequal to do better), and data of
fewer than :data:`MIN_GROUPS` sequences are cut into :data:`N_BLOCKS` contiguous blocks in
measurement order (:func:`split_groups`). :func:`check_enough_data` refuses data too small
for a split -- one row, identical rows, fewer distinct commands than a fit needs -- with the
minimum in the message, before any training starts (a degenerate model would otherwise be
written with exit code 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError

#: How ``--split`` divides the rows: one by one at random, or whole sequences.
SPLIT_KINDS = ("random", "group")
#: A group split of data with fewer sequences than this cuts them into N_BLOCKS blocks.
MIN_GROUPS, N_BLOCKS = 3, 10
#: A split whose training set holds fewer than this share of the rows its ratios give is warned about.
MIN_TRAIN_SHARE = 0.5


@dataclass
class Split:
    """Sample indices of the training, validation and test sets (sorted, disjoint).

    Attributes
    ----------
    train, validation, test : numpy.ndarray
        Row indices of each set, int, sorted.
    """

    train: np.ndarray
    validation: np.ndarray
    test: np.ndarray

    def sizes(self) -> dict:
        """The number of rows of each set.

        Returns
        -------
        dict
            ``train``, ``validation``, ``test`` -> int.
        """
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


def split_groups(seq_ids) -> tuple[np.ndarray, str]:
    """The groups a group split deals out, (N,) ints, and what they are: ``"sequences"``
    (``seq_ids`` itself) or, for fewer than :data:`MIN_GROUPS` sequences,
    ``"contiguous_blocks"``: :data:`N_BLOCKS` blocks in row order (fewer for fewer rows)."""
    from lab.data.sequences import contiguous_blocks

    ids = np.asarray(seq_ids)
    n_groups = 1 + int(np.count_nonzero(ids[1:] != ids[:-1])) if len(ids) else 0
    if n_groups >= MIN_GROUPS:
        return ids, "sequences"
    return contiguous_blocks(len(ids), min(N_BLOCKS, max(len(ids), 1))), "contiguous_blocks"


def divide_groups(groups, ratios=(0.8, 0.1, 0.1), seed: int | np.random.Generator = 0) -> Split:
    """A split that keeps each group (``groups`` (N,): a run of equal consecutive values is
    one group, e.g. one measurement sequence) whole on one side.

    Groups are taken in a seeded random order; the test set, then the validation set, takes
    each group that brings its row count closer to ``round(ratio * N)``, keeping back one
    group for each set still to fill; a set whose ratio is > 0 and that no group brought
    closer takes the smallest group left (so one long sequence of unequal ones stays in
    training rather than leaving it a sliver); training gets the rest. InputError for fewer
    groups than the sets asked for."""
    divide_random(1, ratios)  # checks the ratios
    g = np.asarray(groups)
    n = len(g)
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]]) if n else np.zeros(0, int)
    bounds = list(zip(starts, [*starts[1:], n]))
    r = np.asarray(ratios, dtype=float) / float(np.sum(ratios))
    asked = [s for s in (2, 1) if r[s] > 0]
    if len(bounds) < 1 + len(asked):
        raise InputError(
            f"a group split {tuple(ratios)} needs at least {1 + len(asked)} sequences (one per set), got {len(bounds)}"
        )
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    left = [int(i) for i in rng.permutation(len(bounds))]
    sets = {0: [], 1: [], 2: []}
    for pos, s in enumerate(asked):
        target, count = int(round(r[s] * n)), 0
        for i in list(left):
            size = bounds[i][1] - bounds[i][0]
            keep_back = len(asked) - pos  # train and the sets after this one need a group each
            if len(left) <= keep_back:
                break
            if abs(count + size - target) < abs(count - target):
                sets[s].append(i)
                left.remove(i)
                count += size
        if not sets[s]:  # every group overshoots: the smallest, the first of equals in the random order
            smallest = min(left, key=lambda i: bounds[i][1] - bounds[i][0])
            sets[s].append(smallest)
            left.remove(smallest)
    sets[0] = left
    idx = [np.sort(np.concatenate([np.arange(*bounds[i]) for i in sets[s]] or [np.zeros(0, int)])) for s in range(3)]
    return Split(*(a.astype(int) for a in idx))


def thin_training_note(n_train: int, n_rows: int, ratios) -> str | None:
    """A warning when a split's training set holds fewer than :data:`MIN_TRAIN_SHARE` of
    the rows the ratios give it (whole sequences of unequal length can leave training a
    sliver); None when it holds enough.

    Parameters
    ----------
    n_train : int
        Rows in the training set.
    n_rows : int
        Rows split.
    ratios : sequence of float
        (train, validation, test).

    Returns
    -------
    str or None
        The warning, naming both counts.
    """
    expected = _sizes(n_rows, ratios)[0]
    if n_train >= MIN_TRAIN_SHARE * expected:
        return None
    return (
        f"the group split trains on {n_train} of {n_rows} rows, under {100 * MIN_TRAIN_SHARE:.0f} % of the "
        f"{expected} its ratios {tuple(float(r) for r in ratios)} give: the sequences are too unequal to hold out "
        "whole ones near the ratios; the errors are those of a model fitted on a sliver"
    )


def _sizes(n: int, ratios) -> tuple[int, int, int]:
    r = np.asarray(ratios, dtype=float)
    r = r / r.sum()
    n_val, n_test = int(round(r[1] * n)), int(round(r[2] * n))
    return n - n_val - n_test, n_val, n_test


def minimum_samples(n_inputs: int, ratios) -> int:
    """The fewest samples a split ``ratios`` of an ``n_inputs``-input dataset may have: the
    training set needs ``n_inputs + 1`` samples (an affine map is the least a network must
    fit) and every set the ratios ask for needs at least one.

    Parameters
    ----------
    n_inputs : int
        Inputs n_u of the dataset.
    ratios : sequence of float
        (train, validation, test), normalised by their sum.

    Returns
    -------
    int
        The fewest samples.
    """
    r = np.asarray(ratios, dtype=float)
    for n in range(1, 100_000):
        n_train, n_val, n_test = _sizes(n, r)
        if n_train >= n_inputs + 1 and (n_val >= 1 or r[1] == 0) and (n_test >= 1 or r[2] == 0):
            return n
    raise InputError(f"split ratios {tuple(ratios)} never give usable sets")


def check_enough_data(u: np.ndarray, ratios) -> None:
    """Raise InputError unless the commands ``u`` (N, n_u) can be split by ``ratios`` into
    usable sets: at least :func:`minimum_samples` samples and as many *distinct* commands.

    Parameters
    ----------
    u : numpy.ndarray
        Commands, shape (N, n_u), rad.
    ratios : sequence of float
        (train, validation, test).
    """
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


def divide(n: int, ratios, seed: int | np.random.Generator = 0, groups=None) -> Split:
    """:func:`divide_random` of ``n`` rows, or with ``groups`` (n,) :func:`divide_groups`;
    InputError if the training part then has fewer than 2 rows."""
    if groups is None:
        return divide_random(n, ratios, seed)
    if len(groups) != n:
        raise InputError(f"groups must give one group per row: {len(groups)} for {n} rows")
    split = divide_groups(groups, ratios, seed)
    if len(split.train) < 2:
        raise InputError(f"the group split {tuple(ratios)} leaves {len(split.train)} training rows; need at least 2")
    return split
