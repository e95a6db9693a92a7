"""The settings of a training run: :class:`TrainSpec`, the typed form of the model flags.

Which model (``--model``), its network (``--hidden``, ``--activation``), how it is trained
(``--algorithm``, ``--epochs``, ``--min-grad``, ``--members``), the past commands it takes
(``--history``, :mod:`lab.learn.history`), the split (``--split``: ratios, and ``random``
rows or whole ``group`` sequences), the seed and the worker processes (``--jobs``) are the
fields of one frozen spec, each
declared with :func:`lab.specs.option`, so that the flags' help and checks live here:
``train`` and ``splits`` build their flags from it, ``transfer`` its ``--hidden`` and
``--seed``. :meth:`TrainSpec.check_fits` refuses, once the data's sizes are known, a
network that cannot fit in memory (:mod:`lab.learn.network_size`). The ``splits`` study's
own setting, the number of random splits, is :class:`lab.jobs.splits.SplitsSpec`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral

from lab.errors import FieldError
from lab.learn.algorithm_choice import choose_algorithm
from lab.learn.history import MAX_HISTORY
from lab.learn.mlp import ACTIVATIONS
from lab.learn.model_specs import model_spec
from lab.learn.models import MODEL_CHOICES, net_options
from lab.learn.network_size import check_network_size
from lab.learn.split import SPLIT_KINDS
from lab.learn.train import ALGORITHMS
from lab.specs import Spec, at_most, non_negative, non_negative_int, option, positive_int

__all__ = ["TrainSpec"]

#: How an error names the split ratios (the command line's ``--split``).
_RATIOS = "TrainSpec.ratios"


def _widths(v) -> str | None:
    ok = len(v) > 0 and all(isinstance(h, Integral) and not isinstance(h, bool) and h >= 1 for h in v)
    return None if ok else "widths must be positive integers"


def _ratios(v) -> str | None:
    ok = (
        len(v) == 3
        and all(isinstance(r, (int, float)) and not isinstance(r, bool) and math.isfinite(r) and r >= 0 for r in v)
        and v[0] > 0
    )
    return None if ok else "must be 3 non-negative numbers (train, validation, test) with train > 0"


def _split_words(value, kind: str, default) -> tuple[str, object]:
    """(kind, ratios) of a ``--split`` value: 3 ratios, a word of :data:`SPLIT_KINDS`, or
    the word then 3 ratios (words and numbers as the command line gives them, strings)."""
    if not isinstance(value, (tuple, list)):
        return kind, value
    words = list(value)
    if words and isinstance(words[0], str) and words[0].strip().lower() in SPLIT_KINDS:
        kind, words = words[0].strip().lower(), words[1:]
        if not words:
            return kind, default
    elif words and isinstance(words[0], str) and not _is_number_word(words[0]):
        raise FieldError(
            f"{_RATIOS} must start with one of {', '.join(SPLIT_KINDS)} or be 3 ratios, got {words[0]!r}", _RATIOS
        )
    if len(words) != 3:
        raise FieldError(
            f"{_RATIOS} takes 3 ratios (TRAIN VAL TEST), a word ({', '.join(SPLIT_KINDS)}) or the word and 3 "
            f"ratios, got {' '.join(map(str, value))!r}",
            _RATIOS,
        )
    out = []
    for w in words:
        if isinstance(w, str):
            if not _is_number_word(w):
                raise FieldError(f"{_RATIOS} ratio {w!r} is not a number", _RATIOS)
            w = float(w)
        out.append(w)
    return kind, tuple(out)


def _is_number_word(w: str) -> bool:
    try:
        float(w)
    except ValueError:
        return False
    return True


@dataclass(frozen=True)
class TrainSpec(Spec):
    """A model and how it is trained; see each field's help.

    Parameters
    ----------
    model : str
        One of :data:`lab.learn.MODEL_CHOICES`: lab's network, an ensemble, a scikit-learn
        peer or the direct inverse.
    hidden : tuple of int
        Hidden layer widths.
    algorithm : str
        Network training: ``lm``, ``adam``, ``lbfgs``, ``br``, ``lm-subsample`` or ``auto``
        (by size; :meth:`resolved` picks).
    activation : str
        Hidden activation.
    epochs : int, optional
        Maximum epochs (None: 1000).
    min_grad : float, optional
        LM/BR gradient stop (None: the algorithm's default; 0 disables).
    members : int
        Ensemble: number of networks (at least 2).
    ratios : tuple of float
        Split ratios (train, validation, test); also takes the ``--split`` words, parsed
        into ``split`` and ``ratios``.
    split : str
        ``random`` rows or ``group``: whole measurement sequences.
    history : int
        Past commands the model also takes (0: the command only).
    seed : int
        Seed of the split and the initial weights.
    jobs : int
        Worker processes (an ensemble's members; the splits of ``splits``).
    """

    model: str = option(
        "mlp",
        choices=MODEL_CHOICES,
        help="lab's network, a deep ensemble of them, or a scikit-learn peer "
        "(Gaussian process, k-nearest neighbours, MLPRegressor), or the direct inverse u = g(y)",
    )
    hidden: tuple[int, ...] = option((20, 20), type=int, check=_widths, help="hidden layer widths")
    algorithm: str = option(
        "auto",
        choices=ALGORITHMS,
        help="network training: Levenberg-Marquardt (MATLAB trainlm), Adam, L-BFGS, Bayesian regularisation "
        "(MATLAB trainbr), LM whose curvature comes from a random sample of rows each epoch (lm-subsample, for "
        "large datasets), or auto (the default): lm while LM's epoch is cheap (training rows x outputs x "
        "parameters^2 <= 2e9), lm-subsample above",
    )
    activation: str = option("tanh", choices=ACTIVATIONS, help="hidden activation")
    epochs: int | None = option(None, type=int, check=positive_int, help="maximum epochs (default 1000)")
    min_grad: float | None = option(
        None,
        type=float,
        check=non_negative,
        help="LM/BR: gradient stop (default 1e-6 for lm, 1e-7 for br, none for lm-subsample; 0 disables)",
    )
    members: int = option(5, type=int, check=positive_int, help="ensemble: number of networks K >= 2")
    ratios: tuple[float, float, float] = option(
        (0.8, 0.1, 0.1),
        type=str,
        check=_ratios,
        help="split ratios (train, validation, test), after an optional word: random rows like MATLAB "
        "dividerand (the default), or group: whole measurement sequences (the sidecar's sequence_starts; "
        "fewer than 3 are cut into 10 contiguous blocks); a word alone keeps the default ratios",
    )
    split: str = option("random", choices=SPLIT_KINDS, cli=False, help="random rows or whole sequences (--split)")
    history: int = option(
        0,
        type=int,
        check=at_most(MAX_HISTORY, non_negative_int),
        help="past commands the model also takes: inputs u_t, u_{t-1}, ..., u_{t-K} within each measurement "
        f"sequence (0: the command only; at most {MAX_HISTORY}, and below the longest sequence)",
    )
    seed: int = option(0, type=int, check=non_negative_int, help="seed of the split and the initial weights")
    jobs: int = option(1, type=int, check=positive_int, help="ensemble: worker processes training the members")

    def __post_init__(self):
        default = type(self).__dataclass_fields__["ratios"].default
        kind, ratios = _split_words(self.ratios, self.split, default)
        object.__setattr__(self, "split", kind)  # frozen: the parsed words, once
        object.__setattr__(self, "ratios", ratios)
        super().__post_init__()
        if self.model == "ensemble" and self.members < 2:
            raise self.field_error(f"{self.name_of('members')} must be at least 2, got {self.members}", "members")
        if self.model == "inverse-mlp" and self.history:
            raise self.field_error(
                f"{self.name_of('history')} applies to forward models; {self.name_of('model')} inverse-mlp maps a "
                "tip to a command and takes no past",
                "history",
                "model",
            )

    def model_spec(self):
        """The model this spec fits, for :func:`lab.learn.models.fit_model` and
        :func:`lab.learn.models.evaluate_model_splits`.

        Returns
        -------
        NetworkSpec, EnsembleSpec, InverseSpec, GPRSpec, KNNSpec or SklearnMLPSpec
            :func:`lab.learn.model_specs.model_spec` of ``model`` with this spec's hidden
            widths, algorithm, epochs, gradient stop, activation, members, seed and
            ``jobs`` (the ensemble's workers).
        """
        return model_spec(
            self.model,
            hidden=tuple(self.hidden),
            algorithm=self.algorithm,
            epochs=self.epochs,
            options=net_options(self.algorithm, self.min_grad),
            activation=self.activation,
            members=self.members,
            seed=self.seed,
            n_jobs=self.jobs,
        )

    def resolved(self, n_u: int, n_y: int, n_samples: int) -> tuple[TrainSpec, str | None]:
        """This spec with ``algorithm`` ``auto`` replaced by the trainer
        :func:`lab.learn.algorithm_choice.choose_algorithm` picks for its network on the
        training rows of ``n_samples`` (:meth:`n_train`), and the reason in words; the spec
        itself and None for another algorithm or a model without a network.

        Parameters
        ----------
        n_u, n_y : int
            Inputs and outputs of the data.
        n_samples : int
            Samples of the dataset.

        Returns
        -------
        spec : TrainSpec
            The spec with a concrete algorithm.
        reason : str or None
            Why, e.g. "auto: 831 residuals x 563 parameters, ..."; None when nothing was chosen.
        """
        if self.algorithm != "auto" or self.model not in ("mlp", "ensemble", "inverse-mlp"):
            return self, None
        sizes = (n_y, *self.hidden, n_u) if self.model == "inverse-mlp" else (n_u, *self.hidden, n_y)
        algorithm, reason = choose_algorithm(sizes, self.n_train(n_samples))
        return self.replace(algorithm=algorithm), reason

    def n_train(self, n_samples: int) -> int:
        """Samples in the training part of ``n_samples`` split by ``ratios`` (dividerand).

        Parameters
        ----------
        n_samples : int
            Samples of the dataset.

        Returns
        -------
        int
            Training samples.
        """
        total = sum(self.ratios)
        return n_samples - sum(int(round(r / total * n_samples)) for r in self.ratios[1:])

    def check_fits(self, n_u: int, n_y: int, n_samples: int, copies: int = 1) -> None:
        """Refuse (InputError naming ``--hidden``) a network this spec would train on
        ``n_samples`` samples of ``n_u`` inputs and ``n_y`` outputs, ``copies`` runs at once,
        that would not fit in the memory available now. Nothing to check for gpr and knn.

        Parameters
        ----------
        n_u, n_y : int
            Inputs and outputs of the data.
        n_samples : int
            Samples of the dataset.
        copies : int
            Runs at once.
        """
        if self.model in ("gpr", "knn"):
            return
        sizes = (n_y, *self.hidden, n_u) if self.model == "inverse-mlp" else (n_u, *self.hidden, n_y)
        algorithm = "adam" if self.model == "sklearn-mlp" else self.algorithm
        parallel = min(self.jobs, self.members) if self.model == "ensemble" else 1
        check_network_size(sizes, self.n_train(n_samples), algorithm, copies=copies * parallel)
