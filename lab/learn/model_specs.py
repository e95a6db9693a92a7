"""What :func:`lab.learn.models.fit_model` fits: one frozen spec per model kind.

A spec holds exactly the settings its kind uses: :class:`NetworkSpec` (kind ``mlp``: the
network trained by :func:`lab.learn.train.train`), :class:`EnsembleSpec` (``ensemble``:
K such networks, :func:`lab.learn.ensemble.train_ensemble`), :class:`InverseSpec`
(``inverse-mlp``: the direct inverse, :func:`lab.learn.inverse.fit_inverse`) and the
scikit-learn peers' :class:`GPRSpec`, :class:`KNNSpec` and :class:`SklearnMLPSpec`
(:mod:`lab.learn.peers`). :data:`MODEL_SPECS` maps the kind's name (``--model``) to its
class; :func:`model_spec` builds one from a name and settings.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import ClassVar

from lab.errors import InputError
from lab.learn.train import check_options

__all__ = [
    "EnsembleSpec",
    "GPRSpec",
    "InverseSpec",
    "KNNSpec",
    "MODEL_SPECS",
    "NetworkSpec",
    "SklearnMLPSpec",
    "model_spec",
]


def _widths(hidden) -> tuple[int, ...]:
    return tuple(int(h) for h in hidden)


@dataclass(frozen=True)
class NetworkSpec:
    """A network u -> y trained by :func:`lab.learn.train.train` on a split of its data.

    Parameters
    ----------
    hidden : tuple of int
        Hidden layer widths.
    algorithm : str
        One of ``lab.learn.train.ALGORITHMS``.
    epochs : int, optional
        Maximum number of epochs (None: the options').
    options : LMOptions, BROptions, AdamOptions or LBFGSOptions, optional
        The algorithm's options (``lab.learn.train.ALGORITHM_OPTIONS``); None: its defaults.
    ratios : tuple of float, optional
        (train, validation, test) split of the data the model is fitted to; None:
        :func:`lab.learn.ensemble.member_ratios` (10 % validation, none for "br").
    activation : str
        Hidden activation.
    seed : int
        Seed of the split and the initial weights.
    """

    kind: ClassVar[str] = "mlp"
    hidden: tuple[int, ...] = (20, 20)
    algorithm: str = "lm"
    epochs: int | None = None
    options: object = None
    ratios: tuple[float, ...] | None = None
    activation: str = "tanh"
    seed: int = 0

    def __post_init__(self):
        object.__setattr__(self, "hidden", _widths(self.hidden))
        if self.ratios is not None:
            object.__setattr__(self, "ratios", tuple(self.ratios))
        check_options(self.algorithm, self.options)

    def train_kwargs(self) -> dict:
        """The keyword arguments of :func:`lab.learn.train.train` this spec gives, the
        split ratios' default resolved.

        Returns
        -------
        dict
            ``algorithm``, ``epochs``, ``options``, ``activation`` and ``ratios``.
        """
        from lab.learn.ensemble import member_ratios

        ratios = self.ratios if self.ratios is not None else member_ratios(self.algorithm)
        return {
            "algorithm": self.algorithm,
            "epochs": self.epochs,
            "options": self.options,
            "activation": self.activation,
            "ratios": ratios,
        }


@dataclass(frozen=True)
class EnsembleSpec(NetworkSpec):
    """A deep ensemble: ``members`` networks of :class:`NetworkSpec`'s settings, member k
    seeded by ``run_seeds(seed, members)[k]``.

    Parameters
    ----------
    hidden, algorithm, epochs, options, ratios, activation, seed
        As :class:`NetworkSpec`, for every member.
    members : int
        K >= 2.
    n_jobs : int
        Worker processes training the members (the result does not depend on it).
    """

    kind: ClassVar[str] = "ensemble"
    members: int = 5
    n_jobs: int = 1


@dataclass(frozen=True)
class InverseSpec(NetworkSpec):
    """The direct inverse u = g(y): a network y -> u of :class:`NetworkSpec`'s settings.

    Parameters
    ----------
    hidden, algorithm, epochs, options, ratios, activation, seed
        As :class:`NetworkSpec`.
    """

    kind: ClassVar[str] = "inverse-mlp"


@dataclass(frozen=True)
class GPRSpec:
    """Gaussian-process regression (:func:`lab.learn.peers.fit_gpr`).

    Parameters
    ----------
    seed : int
        Seed of the optimiser's restarts (and of a subsample).
    """

    kind: ClassVar[str] = "gpr"
    seed: int = 0


@dataclass(frozen=True)
class KNNSpec:
    """k-nearest-neighbour regression (:func:`lab.learn.peers.fit_knn`), inverse-distance weights.

    Parameters
    ----------
    n_neighbors : int
        k.
    """

    kind: ClassVar[str] = "knn"
    n_neighbors: int = 5


@dataclass(frozen=True)
class SklearnMLPSpec:
    """scikit-learn's ``MLPRegressor`` (:func:`lab.learn.peers.fit_sklearn_mlp`).

    Parameters
    ----------
    hidden : tuple of int
        Hidden layer widths.
    seed : int
        Seed of its initial weights and shuffles.
    """

    kind: ClassVar[str] = "sklearn-mlp"
    hidden: tuple[int, ...] = (20, 20)
    seed: int = 0

    def __post_init__(self):
        object.__setattr__(self, "hidden", _widths(self.hidden))


#: model kind (``--model``) -> its spec class, in :data:`lab.learn.models.MODEL_CHOICES`' order
MODEL_SPECS = {cls.kind: cls for cls in (NetworkSpec, EnsembleSpec, GPRSpec, KNNSpec, SklearnMLPSpec, InverseSpec)}

#: every setting some model kind takes (:func:`model_spec`)
_SETTINGS = {f.name for cls in MODEL_SPECS.values() for f in fields(cls)}


def model_spec(kind: str, **settings):
    """The spec of model ``kind`` from settings shared by all kinds, e.g. a command's flags.

    Parameters
    ----------
    kind : str
        One of :data:`MODEL_SPECS`.
    **settings
        Fields of any spec of :data:`lab.learn.model_specs.MODEL_SPECS` (``hidden``,
        ``algorithm``, ``epochs``, ``options``, ``ratios``, ``activation``, ``seed``,
        ``members``, ``n_jobs``, ``n_neighbors``); those ``kind``'s spec has no field for
        are left out, as a command's flag that applies to other models.

    Returns
    -------
    NetworkSpec, EnsembleSpec, InverseSpec, GPRSpec, KNNSpec or SklearnMLPSpec
        The spec of ``kind``.

    Raises
    ------
    InputError
        For an unknown kind, a setting no kind takes, or options of another algorithm's type.
    """
    if kind not in MODEL_SPECS:
        raise InputError(f"model must be one of {tuple(MODEL_SPECS)}, got {kind!r}")
    unknown = sorted(set(settings) - _SETTINGS)
    if unknown:
        raise InputError(f"no model takes the settings {unknown} (known: {sorted(_SETTINGS)})")
    cls = MODEL_SPECS[kind]
    own = {f.name for f in fields(cls)}
    return cls(**{k: v for k, v in settings.items() if k in own})
