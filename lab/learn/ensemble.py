"""A deep ensemble of forward networks: a predictive mean, its Jacobian, and a spread.

K networks (:class:`lab.learn.mlp.MLP`, K >= 2) trained on the same data from different
seeds (:func:`train_ensemble`) give, for a command u (rad): the mean of the members' tips
(m), its Jacobian (the mean of theirs, m/rad), and the spread std(u) (m, per coordinate):
the sample standard deviation across members times a post-hoc **spread scale** ``s`` (1
unless fitted with :meth:`Ensemble.fit_spread_scale` on held-out data: deep ensembles of a
few members are usually over-confident). :meth:`Ensemble.std_and_jacobian` also gives
dstd/du, for IK that penalises the spread; :func:`calibration` measures how well the spread
predicts held-out errors. One ``.npz`` file (no pickle) holds every member's arrays under
``m0.``, ``m1.``, ... and a ``metadata`` JSON with ``kind: "lab.ensemble"`` and the spread scale.

The formulas: docs/design/learn.md.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from lab.errors import InputError
from lab.files import atomic_open, json_default
from lab.learn.mlp import ACTIVATIONS, MLP
from lab.learn.model_io import FORMAT_VERSION, ModelFileError, _read_arrays, file_metadata, model_arrays, read_model

__all__ = ["ENSEMBLE_KIND", "Ensemble", "train_ensemble", "load_ensemble", "calibration", "member_ratios"]

ENSEMBLE_KIND = "lab.ensemble"
GAUSS_1SIGMA, GAUSS_2SIGMA = 0.6827, 0.9545  # P(|z| <= 1), P(|z| <= 2) for z ~ N(0, 1)


class Ensemble:
    """``members`` (list of :class:`MLP`, K >= 2, equal n_u and n_y); ``spread_scale`` s > 0
    multiplies the raw member spread; ``metadata`` is saved with the file."""

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
        """f_k(u) for every member: (K, N, n_y) m for u (N, n_u), or (K, n_y) for u (n_u,)."""
        return np.stack([m.predict(u) for m in self.members])

    def predict(self, u) -> np.ndarray:
        """Mean prediction (N, n_y) m for u (N, n_u) rad; (n_y,) for a single u (n_u,)."""
        return self.member_predictions(u).mean(axis=0)

    def predict_and_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Mean (N, n_y) m and its Jacobian, the mean of the members' (N, n_y, n_u) m/rad;
        a single u (n_u,) gives (n_y,) and (n_y, n_u)."""
        parts = [m.predict_and_jacobian(u) for m in self.members]
        return np.mean([p[0] for p in parts], axis=0), np.mean([p[1] for p in parts], axis=0)

    def jacobian(self, u) -> np.ndarray:
        """d mean / du (N, n_y, n_u) m/rad, or (n_y, n_u) for a single u."""
        return self.predict_and_jacobian(u)[1]

    def predict_with_std(self, u, scaled: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(mean, std), both (N, n_y) m for u (N, n_u) rad, or (n_y,) for one u: std is the
        sample standard deviation across members (ddof 1) per coordinate, times the spread
        scale unless ``scaled=False``."""
        f = self.member_predictions(u)
        std = f.std(axis=0, ddof=1)
        return f.mean(axis=0), std * self.spread_scale if scaled else std

    def std_and_jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """Scaled std (N, n_y) m and d std / du (N, n_y, n_u) m/rad (formula in the module
        docstring; zero where the members agree exactly); (n_y,), (n_y, n_u) for one u."""
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
        the 68.27th percentile of |y - mean| / std_raw over all coordinates, so that 68.27 %
        of those errors fall within 1 sigma (robust to a few outliers, unlike a Gaussian
        maximum-likelihood scale)."""
        u, y = np.asarray(u, float), np.asarray(y, float)
        if u.ndim != 2 or y.shape != (len(u), self.n_y) or len(u) < 1:
            raise InputError(f"expected u (N, {self.n_u}) and y (N, {self.n_y}) with N >= 1, got {u.shape}, {y.shape}")
        mean, std = self.predict_with_std(u, scaled=False)
        z = _z_scores(y, mean, std)
        s = float(np.quantile(z[np.isfinite(z)], GAUSS_1SIGMA)) if np.any(np.isfinite(z)) else 1.0
        self.spread_scale = s if np.isfinite(s) and s > 0 else 1.0
        self.metadata["spread_scale_fit"] = {"method": "quantile_68", "n": int(len(u)), "scale": self.spread_scale}
        return self.spread_scale

    def save(self, path) -> Path:
        """Write every member and the metadata to one ``.npz`` atomically (no pickle)."""
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
    and the problem (missing, corrupt, another kind, a bad member or spread scale)."""
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


def train_ensemble(u, y, hidden=(20, 20), k: int = 5, seed: int = 0, n_jobs: int = 1, **train_kwargs) -> Ensemble:
    """Train K members on u (N, n_u) rad -> y (N, n_y) m with :func:`lab.learn.train.train`,
    member k with seed ``run_seeds(seed, k)[k]`` (its own initial weights and validation
    split); ``train_kwargs`` (algorithm, epochs, options, activation, ratios, ...) go to
    every member, ``ratios`` defaulting to :func:`member_ratios`. ``n_jobs`` > 1 trains
    members on joblib workers (results do not depend on it)."""
    from lab.learn.studies import run_seeds
    from lab.learn.train import data_sha256

    if int(k) < 2:
        raise InputError(f"an ensemble needs at least 2 members, got k={k}")
    if int(n_jobs) < 1:
        raise InputError(f"n_jobs must be positive, got {n_jobs}")
    u, y = np.asarray(u, float), np.asarray(y, float)
    kwargs = {"ratios": member_ratios(train_kwargs.get("algorithm", "lm")), **train_kwargs}
    hidden = tuple(int(h) for h in hidden)
    seeds = run_seeds(seed, int(k))
    jobs = [(u, y, hidden, s, kwargs) for s in seeds]
    if n_jobs == 1:
        members = [_train_member(*job) for job in jobs]
    else:
        from joblib import Parallel, delayed

        from lab.workers import kill_local_workers, worker_config

        try:
            with worker_config():
                members = Parallel(n_jobs=n_jobs)(delayed(_train_member)(*job) for job in jobs)
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


def _z_scores(y_true, mean, std) -> np.ndarray:
    err = np.abs(np.asarray(y_true, float) - mean)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(std > 0, err / np.where(std > 0, std, 1.0), np.where(err > 0, np.inf, 0.0))


def calibration(y_true, mean, std) -> dict:
    """How well a predicted spread explains held-out errors. ``y_true``, ``mean``, ``std``:
    (N, n_y) m (std > 0; a zero std counts any error as outside every interval).

    Per coordinate, ``z = |y_true - mean| / std`` over all N * n_y entries:
    ``within_1sigma`` = fraction with z <= 1 and ``within_2sigma`` with z <= 2, to compare
    with the Gaussian ``gaussian_1sigma`` = 0.6827 and ``gaussian_2sigma`` = 0.9545;
    ``rms_z`` = sqrt(mean z^2) over the finite z (1 when calibrated; > 1 over-confident).
    Per sample, the normalised error radius ``d = sqrt(sum_i z_i^2)`` is chi-distributed
    with n_y degrees of freedom if the errors are independent Gaussians of the predicted
    std; ``radius_within_68`` and ``radius_within_95`` are the fractions of samples with
    d below chi(n_y)'s 0.6827 and 0.9545 quantiles (``chi_q68``, ``chi_q95``: 1.878 and
    2.833 for n_y = 3). Fractions below the Gaussian reference mean over-confidence."""
    y_true, mean, std = (np.asarray(a, float) for a in (y_true, mean, std))
    if y_true.ndim != 2 or mean.shape != y_true.shape or std.shape != y_true.shape or len(y_true) == 0:
        raise InputError(
            f"y_true, mean and std must share one (N, n_y) shape, got {y_true.shape}, {mean.shape}, {std.shape}"
        )
    z = _z_scores(y_true, mean, std)
    d = np.sqrt(np.sum(z * z, axis=1))
    finite = np.isfinite(z)
    n_y = y_true.shape[1]
    q68, q95 = (float(np.sqrt(chi2.ppf(p, n_y))) for p in (GAUSS_1SIGMA, GAUSS_2SIGMA))
    return {
        "n": int(len(y_true)),
        "within_1sigma": float(np.mean(z <= 1.0)),
        "within_2sigma": float(np.mean(z <= 2.0)),
        "gaussian_1sigma": GAUSS_1SIGMA,
        "gaussian_2sigma": GAUSS_2SIGMA,
        "rms_z": float(np.sqrt(np.mean(z[finite] ** 2))) if np.any(finite) else None,
        "radius_within_68": float(np.mean(d <= q68)),
        "radius_within_95": float(np.mean(d <= q95)),
        "chi_q68": q68,
        "chi_q95": q95,
    }
