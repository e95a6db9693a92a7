"""A deep ensemble of forward networks: a predictive mean, its Jacobian, and a spread.

K networks (:class:`lab.learn.mlp.MLP`, K >= 2) trained on the same data from different
seeds (:func:`train_ensemble`) give, for a command u (rad): the mean of the members' tips
(m), its Jacobian (the mean of theirs, m/rad), and the spread std(u) (m, per coordinate):
the sample standard deviation across members times a post-hoc **spread scale** ``s`` (1
unless fitted with :meth:`Ensemble.fit_spread_scale` on held-out data: deep ensembles of a
few members are usually over-confident). :meth:`Ensemble.std_and_jacobian` also gives
dstd/du, for IK that penalises the spread; :func:`lab.learn.spread_calibration.calibration`
measures how well the spread predicts held-out errors. One ``.npz`` file (no pickle) holds every member's arrays under
``m0.``, ``m1.``, ... and a ``metadata`` JSON with ``kind: "lab.ensemble"`` and the spread scale.

The formulas: docs/design/learn.md.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_open, json_default
from lab.learn.mlp import ACTIVATIONS, MLP
from lab.learn.model_io import FORMAT_VERSION, ModelFileError, _read_arrays, file_metadata, model_arrays, read_model
from lab.learn.spread_calibration import GAUSS_1SIGMA, z_scores

__all__ = ["ENSEMBLE_KIND", "Ensemble", "train_ensemble", "load_ensemble", "member_ratios"]

ENSEMBLE_KIND = "lab.ensemble"


class Ensemble:
    """K forward networks with a predictive mean, its Jacobian and a spread.

    Parameters
    ----------
    members : sequence of MLP
        K >= 2 networks with equal n_u and n_y.
    metadata : dict, optional
        Saved with the file.
    spread_scale : float
        s > 0, multiplies the raw member spread.
    """

    kind = ENSEMBLE_KIND
    has_jacobian = True

    def __init__(self, members, metadata: dict | None = None, spread_scale: float = 1.0):
        self.members = list(members)
        if len(self.members) < 2:
            raise InputError(f"an ensemble needs at least 2 members, got {len(self.members)}")
        shapes = {(m.n_u, m.n_y) for m in self.members}
        if len(shapes) != 1:
            raise InputError(f"ensemble members map different shapes (n_u, n_y): {sorted(shapes)}")
        s = float(spread_scale)
        if not (np.isfinite(s) and s > 0):
            raise InputError(f"spread_scale must be a positive number, got {spread_scale!r}")
        self.spread_scale = s
        self.metadata = dict(metadata or {})

    n_u = property(lambda self: self.members[0].n_u)
    n_y = property(lambda self: self.members[0].n_y)
    layer_sizes = property(lambda self: self.members[0].layer_sizes)

    def __repr__(self) -> str:
        return f"Ensemble({len(self.members)} x {self.members[0]!r}, spread scale {self.spread_scale:.3g})"

    def member_predictions(self, u) -> np.ndarray:
        """f_k(u) for every member.

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        numpy.ndarray
            Shape (K, N, n_y) or (K, n_y), m.
        """
        return np.stack([m.predict(u) for m in self.members])

    def predict(self, u) -> np.ndarray:
        """The mean prediction.

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        numpy.ndarray
            Shape (N, n_y) or (n_y,), m.
        """
        return self.member_predictions(u).mean(axis=0)

    def predict_and_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Mean (N, n_y) m and its Jacobian, the mean of the members' (N, n_y, n_u) m/rad;
        a single u (n_u,) gives (n_y,) and (n_y, n_u).

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        mean : numpy.ndarray
            Shape (N, n_y) or (n_y,), m.
        J : numpy.ndarray
            d mean / du, shape (N, n_y, n_u) or (n_y, n_u), m/rad.
        """
        parts = [m.predict_and_jacobian(u) for m in self.members]
        return np.mean([p[0] for p in parts], axis=0), np.mean([p[1] for p in parts], axis=0)

    def jacobian(self, u) -> np.ndarray:
        """The Jacobian of the mean.

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        numpy.ndarray
            d mean / du, shape (N, n_y, n_u) or (n_y, n_u), m/rad.
        """
        return self.predict_and_jacobian(u)[1]

    def predict_with_std(self, u, scaled: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(mean, std), both (N, n_y) m for u (N, n_u) rad, or (n_y,) for one u: std is the
        sample standard deviation across members (ddof 1) per coordinate, times the spread
        scale unless ``scaled=False``.

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.
        scaled : bool
            Multiply the spread by the spread scale.

        Returns
        -------
        mean, std : numpy.ndarray
            Shape (N, n_y) or (n_y,), m.
        """
        f = self.member_predictions(u)
        std = f.std(axis=0, ddof=1)
        return f.mean(axis=0), std * self.spread_scale if scaled else std

    def std_and_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Scaled std (N, n_y) m and d std / du (N, n_y, n_u) m/rad (formula in the module
        docstring; zero where the members agree exactly); (n_y,), (n_y, n_u) for one u.

        Parameters
        ----------
        u : array_like
            Commands, shape (N, n_u) or (n_u,), rad.

        Returns
        -------
        std : numpy.ndarray
            Shape (N, n_y) or (n_y,), m.
        dstd : numpy.ndarray
            d std / du, shape (N, n_y, n_u) or (n_y, n_u), m/rad.
        """
        parts = [m.predict_and_jacobian(u) for m in self.members]
        f, J = np.stack([p[0] for p in parts]), np.stack([p[1] for p in parts])
        df, dJ = f - f.mean(axis=0), J - J.mean(axis=0)
        k, s = len(self.members), self.spread_scale
        std = s * np.sqrt(np.sum(df * df, axis=0) / (k - 1))
        safe = np.where(std > 0, std, np.inf)
        dstd = (s * s / (k - 1)) * np.sum(df[..., None] * dJ, axis=0) / safe[..., None]
        return std, dstd

    def fit_spread_scale(self, u, y) -> float:
        """Set and return the spread scale s from held-out data u (N, n_u) rad, y (N, n_y) m:
        the 68.27th percentile of ``|y - mean| / std_raw`` over all coordinates, so that 68.27 %
        of those errors fall within 1 sigma (robust to a few outliers, unlike a Gaussian
        maximum-likelihood scale).

        Parameters
        ----------
        u : array_like
            Held-out commands, shape (N, n_u), rad.
        y : array_like
            Their measured tips, shape (N, n_y), m.

        Returns
        -------
        float
            The spread scale s (> 0; 1 when the data cannot tell).
        """
        u, y = np.asarray(u, float), np.asarray(y, float)
        if u.ndim != 2 or y.shape != (len(u), self.n_y) or len(u) < 1:
            raise InputError(f"expected u (N, {self.n_u}) and y (N, {self.n_y}) with N >= 1, got {u.shape}, {y.shape}")
        mean, std = self.predict_with_std(u, scaled=False)
        z = z_scores(y, mean, std)
        s = float(np.quantile(z[np.isfinite(z)], GAUSS_1SIGMA)) if np.any(np.isfinite(z)) else 1.0
        self.spread_scale = s if np.isfinite(s) and s > 0 else 1.0
        self.metadata["spread_scale_fit"] = {"method": "quantile_68", "n": int(len(u)), "scale": self.spread_scale}
        return self.spread_scale

    def save(self, path) -> Path:
        """Write every member and the metadata to one ``.npz`` atomically (no pickle).

        Parameters
        ----------
        path : str or Path
            The model file.

        Returns
        -------
        Path
            ``path``.
        """
        import datetime as _dt

        from lab.files import code_version

        path = Path(path)
        meta = {
            **{k: v for k, v in self.metadata.items() if k not in ("format_version", "kind")},
            "format_version": FORMAT_VERSION,
            "kind": ENSEMBLE_KIND,
            "n_members": len(self.members),
            "spread_scale": self.spread_scale,
            "code_version": code_version(),
            "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        }
        arrays = {"metadata": np.array(json.dumps(meta, default=json_default, allow_nan=False))}
        for k, m in enumerate(self.members):
            arrays.update({f"m{k}.{key}": v for key, v in model_arrays(m).items()})
        with atomic_open(path, "wb") as fh:
            np.savez(fh, **arrays)
        return path


def load_ensemble(path) -> Ensemble:
    """Read a file written by :meth:`Ensemble.save`; :class:`ModelFileError` naming the file
    and the problem (missing, corrupt, another kind, a bad member or spread scale).

    Parameters
    ----------
    path : str or Path
        The model file.

    Returns
    -------
    Ensemble
        The members, metadata and spread scale as saved.
    """
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"model file not found: {path}")
    meta = file_metadata(path, _read_arrays(path))
    if meta.get("kind") != ENSEMBLE_KIND:
        raise ModelFileError(f"{path}: kind {meta.get('kind')!r} is not {ENSEMBLE_KIND!r}")
    n = meta.get("n_members")
    if not isinstance(n, int) or isinstance(n, bool) or n < 2:
        raise ModelFileError(f"{path}: metadata n_members must be an integer >= 2, got {n!r}")
    members = [MLP(**read_model(path, ACTIVATIONS, prefix=f"m{k}.")) for k in range(n)]
    keep = {k: v for k, v in meta.items() if k not in ("format_version", "kind", "n_members", "spread_scale")}
    try:
        return Ensemble(members, keep, meta.get("spread_scale", 1.0))
    except (InputError, TypeError, ValueError) as err:
        raise ModelFileError(f"{path}: {err}") from None


def member_ratios(algorithm: str = "lm") -> tuple[float, float, float]:
    """Default (train, validation, test) split of each member's data: Bayesian
    regularisation needs no validation set (1, 0, 0); the others stop early on a random
    10 % validation set (0.9, 0.1, 0), a different one per member."""
    return (1.0, 0.0, 0.0) if algorithm == "br" else (0.9, 0.1, 0.0)


def _train_member(u, y, hidden, seed, kwargs):
    from lab.learn.train import train
    from lab.workers import watch_parent

    watch_parent()
    return train(u, y, hidden, seed=seed, **kwargs).model


def train_ensemble(u, y, hidden=(20, 20), k: int = 5, seed: int = 0, n_jobs: int = 1, progress=None,
                   **train_kwargs) -> Ensemble:  # fmt: skip
    """Train K members on u (N, n_u) rad -> y (N, n_y) m with :func:`lab.learn.train.train`,
    member k with seed ``run_seeds(seed, k)[k]`` (its own initial weights and validation
    split); ``train_kwargs`` (algorithm, epochs, options, activation, ratios, ...) go to
    every member, ``ratios`` defaulting to :func:`member_ratios`. ``n_jobs`` > 1 trains
    members on joblib workers (results do not depend on it).

    Parameters
    ----------
    u : array_like
        Commands, shape (N, n_u), rad.
    y : array_like
        Tips, shape (N, n_y), m.
    hidden : tuple of int
        Hidden layer widths of every member.
    k, seed, n_jobs : int
        Members (>= 2), the run's seed and worker processes.
    progress : callable, optional
        ``progress(done, total)``: ``done`` of at most ``total`` = k x the epoch limit
        epochs trained, after every epoch (on several workers: a few times a second, the
        epochs of all of them together, from 0 as the first worker starts training;
        :class:`lab.learn.worker_progress.EpochCounters`).
    **train_kwargs
        Passed to :func:`lab.learn.train`.

    Returns
    -------
    Ensemble
        The trained members, spread scale 1.
    """
    from lab.learn.studies import run_seeds
    from lab.learn.train import data_sha256, max_epochs

    if int(k) < 2:
        raise InputError(f"an ensemble needs at least 2 members, got k={k}")
    if int(n_jobs) < 1:
        raise InputError(f"n_jobs must be positive, got {n_jobs}")
    u, y = np.asarray(u, float), np.asarray(y, float)
    kwargs = {"ratios": member_ratios(train_kwargs.get("algorithm", "lm")), **train_kwargs}
    hidden = tuple(int(h) for h in hidden)
    seeds = run_seeds(seed, int(k))
    jobs = [(u, y, hidden, s, kwargs) for s in seeds]
    epochs = max_epochs(kwargs.get("algorithm", "lm"), kwargs.get("epochs"), kwargs.get("options"))
    total = epochs * len(jobs)
    if n_jobs == 1:
        members = []
        for i, job in enumerate(jobs):
            tell = None if progress is None else (lambda e, row, i=i: progress(i * epochs + e, total))
            members.append(_train_member(*job[:4], {**job[4], "progress": tell} if tell else job[4]))
            if progress is not None:
                progress((i + 1) * epochs, total)
    else:
        import contextlib

        from joblib import Parallel, delayed

        from lab.learn.worker_progress import EpochCounters
        from lab.workers import kill_local_workers, worker_config

        try:
            with (
                worker_config(),
                (
                    EpochCounters([epochs] * len(jobs), progress) if progress is not None else contextlib.nullcontext()
                ) as counters,
            ):
                tell = (lambda i: {"progress": counters.reporter(i)}) if counters is not None else (lambda i: {})
                members = []
                run = Parallel(n_jobs=n_jobs, return_as="generator")(
                    delayed(_train_member)(*job[:4], {**job[4], **tell(i)}) for i, job in enumerate(jobs)
                )
                for member in run:  # in the members' order, each as it is done
                    members.append(member)
                    if counters is not None:
                        counters.finished(len(members) - 1)
        except BaseException:  # Ctrl-C / SIGTERM: stop the workers
            kill_local_workers()
            raise
    training = {
        "members": int(k),
        "seed": seed,
        "member_seeds": seeds,
        "hidden": list(hidden),
        "algorithm": kwargs.get("algorithm", "lm"),
        "member_ratios": list(map(float, kwargs["ratios"])),
        "wall_s": float(sum(m.metadata["training"]["wall_s"] for m in members)),
        "data_sha256": data_sha256(u, y),
        "n_samples": len(u),
    }
    return Ensemble(members, {"training": training, "units": {"u": "rad", "y": "m"}})
