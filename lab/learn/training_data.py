"""The arrays a trainer fits to: one frozen :class:`TrainingData`.

Every trainer (:func:`lab.learn.lm.train_lm`, :func:`lab.learn.bayes.train_br`,
:func:`lab.learn.gradient.train_adam`, :func:`lab.learn.gradient.train_lbfgs`) takes the
network, one :class:`TrainingData` and its algorithm's options object. The training set
decides the steps; the validation set (possibly empty) decides early stopping where the
algorithm has it; the test set (possibly empty) is only recorded, never used for a
decision. :meth:`TrainingData.of_split` cuts the three sets out of one dataset by the
indices of a :class:`lab.learn.split.Split`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError

__all__ = ["TrainingData"]


@dataclass(frozen=True)
class TrainingData:
    """Training, validation and test sets of one u -> y fit, checked for consistent shapes.

    Parameters
    ----------
    u_train : array_like, shape (N_train, n_u)
        Training inputs (the forward model's commands, rad).
    y_train : array_like, shape (N_train, n_y)
        Training targets (tip positions, m).
    u_val, y_val : array_like, shape (N_val, n_u) and (N_val, n_y), optional
        Validation set; None (the default) or empty: no validation set.
    u_test, y_test : array_like, shape (N_test, n_u) and (N_test, n_y), optional
        Test set, only recorded; None (the default) or empty: none.

    Raises
    ------
    InputError
        When an array is not 2-D, a set's inputs and targets differ in rows, the sets
        differ in ``n_u`` or ``n_y``, or only one of a set's two arrays is given.

    Notes
    -----
    The arrays are stored as given when they are already float arrays (a missing set
    becomes an empty (0, n_u), (0, n_y) pair), so a fit sees the caller's very numbers.
    """

    u_train: np.ndarray
    y_train: np.ndarray
    u_val: np.ndarray | None = None
    y_val: np.ndarray | None = None
    u_test: np.ndarray | None = None
    y_test: np.ndarray | None = None

    def __post_init__(self):
        u, y = np.asarray(self.u_train, float), np.asarray(self.y_train, float)
        if u.ndim != 2 or y.ndim != 2 or len(u) != len(y):
            raise InputError(
                f"expected u_train (N, n_u) and y_train (N, n_y) with the same N, got {u.shape} and {y.shape}"
            )
        object.__setattr__(self, "u_train", u)
        object.__setattr__(self, "y_train", y)
        for name in ("val", "test"):
            us, ys = getattr(self, f"u_{name}"), getattr(self, f"y_{name}")
            if (us is None) != (ys is None):
                raise InputError(f"give both u_{name} and y_{name}, or neither")
            if us is None or len(us) == 0:
                us, ys = np.empty((0, u.shape[1])), np.empty((0, y.shape[1]))
            us, ys = np.asarray(us, float), np.asarray(ys, float)
            if (
                us.ndim != 2
                or ys.ndim != 2
                or len(us) != len(ys)
                or us.shape[1:] != u.shape[1:]
                or ys.shape[1:] != y.shape[1:]
            ):
                raise InputError(
                    f"expected u_{name} (N, {u.shape[1]}) and y_{name} (N, {y.shape[1]}) with the same N, "
                    f"got {us.shape} and {ys.shape}"
                )
            object.__setattr__(self, f"u_{name}", us)
            object.__setattr__(self, f"y_{name}", ys)

    @classmethod
    def of_split(cls, u, y, split) -> TrainingData:
        """The three sets of one dataset by a split's indices.

        Parameters
        ----------
        u : array_like, shape (N, n_u)
            Inputs (rad).
        y : array_like, shape (N, n_y)
            Targets (m).
        split : lab.learn.split.Split
            Row indices ``train``, ``validation`` and ``test`` into ``u`` and ``y``.

        Returns
        -------
        TrainingData
            ``u[split.train]``, ``y[split.train]``, and so on.
        """
        u, y = np.asarray(u, float), np.asarray(y, float)
        return cls(
            u[split.train], y[split.train], u[split.validation], y[split.validation], u[split.test], y[split.test]
        )

    @property
    def has_validation(self) -> bool:
        """Whether there is a validation set (at least one row).

        Returns
        -------
        bool
        """
        return len(self.u_val) > 0

    def sets(self) -> dict:
        """The sets by name, as ``error_report`` and training metadata name them.

        Returns
        -------
        dict
            ``{"train": (u, y), "validation": (u, y), "test": (u, y)}``, arrays (N, n_u), (N, n_y).
        """
        return {
            "train": (self.u_train, self.y_train),
            "validation": (self.u_val, self.y_val),
            "test": (self.u_test, self.y_test),
        }
