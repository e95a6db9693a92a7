"""The foam in time: the tip as a learned linear relaxation filter of its quasi-static equilibrium.

A viscoelastic arm creeps toward the equilibrium ``p_eq(u)``. :class:`Relaxation` models the
creep with ``K`` first-order modes (two by default), the same for every axis::

    tau_k dz_k/dt = p_eq(t) - z_k(t),      p_tip(t) = sum_k w_k z_k(t),   sum_k w_k = 1,

integrated exactly for equilibria that move linearly in time (:meth:`Relaxation.interval`).
Being linear in the equilibria makes it cheap to fit (:mod:`lab.dynamics.relaxation_fit`),
to run as a Kalman filter during capture (:mod:`lab.capture.predictive`) and to invert into a
feed-forward command (:meth:`Relaxation.invert`). Saved as ``.npz`` (arrays ``tau_s``,
``weight``, JSON ``metadata`` with ``kind = "lab.dynamics"``); no pickle.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lab.errors import InputError
from lab.files import atomic_open, json_default

FORMAT_VERSION = 1
KIND = "lab.dynamics"


class DynamicsFileError(InputError):
    """A dynamic-model file is missing, corrupt, or of another kind or a newer format."""


@dataclass(frozen=True)
class Relaxation:
    """``K`` relaxation modes, the same for every axis of the tip.

    Attributes
    ----------
    tau_s : numpy.ndarray
        Time constants (K,), s, each > 0.
    weight : numpy.ndarray
        Weights (K,) of the modes, each >= 0, summing to 1.
    noise_sigma_m : float
        Motion-capture noise per axis and frame (m); NaN if unknown.
    info : dict
        JSON-able notes (how it was fitted).
    """

    tau_s: np.ndarray
    weight: np.ndarray
    noise_sigma_m: float = float("nan")
    info: dict = field(default_factory=dict)

    def __post_init__(self):
        tau, w = np.atleast_1d(np.asarray(self.tau_s, float)), np.atleast_1d(np.asarray(self.weight, float))
        if tau.ndim != 1 or tau.shape != w.shape or len(tau) == 0:
            raise InputError(f"tau_s and weight must be two equal-length lists, got {tau!r} and {w!r}")
        if not (np.all(np.isfinite(tau)) and np.all(tau > 0)):
            raise InputError(f"relaxation time constants must be positive seconds, got {tau.tolist()}")
        if not (np.all(np.isfinite(w)) and np.all(w >= 0) and abs(w.sum() - 1.0) < 1e-6):
            raise InputError(f"relaxation weights must be >= 0 and sum to 1, got {w.tolist()}")
        object.__setattr__(self, "tau_s", tau)
        object.__setattr__(self, "weight", w)

    @property
    def n_modes(self) -> int:
        return len(self.tau_s)

    def step(self, t_s) -> np.ndarray:
        """Fraction of an equilibrium step covered ``t_s`` s after it (0 before the step).

        Parameters
        ----------
        t_s : array_like
            Times since the step (s), any shape.

        Returns
        -------
        numpy.ndarray
            The covered fraction in [0, 1], same shape as ``t_s``.
        """
        t = np.asarray(t_s, float)
        covered = 1.0 - np.tensordot(np.exp(-np.maximum(t, 0.0)[..., None] / self.tau_s), self.weight, axes=1)
        return np.where(t > 0, covered, 0.0)

    def settle_time(self, fraction: float) -> float:
        """Seconds after a step until all but ``fraction`` of it is covered.

        Parameters
        ----------
        fraction : float
            The part of the step still to go (e.g. 1e-3), in (0, 1).

        Returns
        -------
        float
            The settling time (s).
        """
        from scipy.optimize import brentq

        return float(brentq(lambda t: 1.0 - self.step(t) - fraction, 0.0, 50.0 * self.tau_s.max()))

    def interval(self, dt_s: float, s0: float = 1.0, s1: float = 1.0):
        """One exactly integrated interval of ``dt_s`` s in which the equilibrium is
        ``e_a (1 - s) + e_b s`` with ``s`` going linearly from ``s0`` to ``s1``.

        Parameters
        ----------
        dt_s : float
            Length of the interval (s), >= 0.
        s0, s1 : float
            The ramp parameter ``s`` (dimensionless) at the start and the end of the interval.

        Returns
        -------
        decay, g_a, g_b : numpy.ndarray
            Each (K,): the modes update as ``z_k <- decay_k z_k + g_a_k e_a + g_b_k e_b``.
        """
        dt = float(dt_s)
        if dt < 0:
            raise InputError(f"time went backwards by {-dt} s")
        x = dt / self.tau_s
        decay = np.exp(-x)
        # c = (dt - tau (1 - decay)) / dt: how much of a ramp's change the mode has caught up
        # with; written with expm1 so that it stays accurate (-> x/2) for short intervals.
        c = np.where(x > 1e-8, 1.0 + np.expm1(-x) / np.where(x > 1e-8, x, 1.0), 0.5 * x)
        ds = s1 - s0
        g_a = (1.0 - decay) * (1.0 - s0) - c * ds
        g_b = (1.0 - decay) * s0 + c * ds
        return decay, g_a, g_b

    def response(self, t_knots_s, p_knots, t_eval_s, z0=None) -> np.ndarray:
        """The filtered tip for an equilibrium that is linear between knots and held after the last.

        Parameters
        ----------
        t_knots_s : array_like
            Knot times (n,), s, non-decreasing.
        p_knots : array_like
            The equilibrium at the knots, (n, d) or (n,) (e.g. m, frame W).
        t_eval_s : array_like
            Times (n_eval,), s, at which to evaluate the tip, in any order.
        z0 : array_like, optional
            The modes (K, d) before the first knot; default settled at ``p_knots[0]``.

        Returns
        -------
        numpy.ndarray
            The tip (n_eval, d) at ``t_eval_s``, in the units of ``p_knots``; (n_eval,) when
            ``p_knots`` is 1-D.
        """
        tk, pk = np.asarray(t_knots_s, float), np.asarray(p_knots, float)
        squeeze = pk.ndim == 1
        pk = pk[:, None] if squeeze else pk
        te = np.asarray(t_eval_s, float)
        if len(tk) != len(pk) or np.any(np.diff(tk) < 0):
            raise InputError("knot times must be non-decreasing, one per knot value")
        z = np.repeat(pk[:1], self.n_modes, axis=0) if z0 is None else np.array(z0, float).reshape(self.n_modes, -1)
        order = np.argsort(te, kind="stable")
        out = np.empty((len(te), pk.shape[1]))
        t, j = tk[0], 0  # j: the next knot ahead of t
        for i in order:
            while t < te[i]:
                if j < len(tk) and tk[j] <= t:
                    j += 1
                    continue
                t_next = min(te[i], tk[j]) if j < len(tk) else te[i]
                if 0 < j < len(tk):
                    span = tk[j] - tk[j - 1]
                    s0, s1 = (t - tk[j - 1]) / span, (t_next - tk[j - 1]) / span
                    ea, eb = pk[j - 1], pk[j]
                else:
                    s0 = s1 = 1.0
                    ea = eb = pk[min(j, len(tk)) - 1] if j else pk[0]
                decay, g_a, g_b = self.interval(t_next - t, s0, s1)
                z = decay[:, None] * z + g_a[:, None] * ea + g_b[:, None] * eb
                t = t_next
            out[i] = self.weight @ z
        return out[:, 0] if squeeze else out

    def invert(self, t_s, p_des, smoothing: float = 1e-3) -> np.ndarray:
        """Feed-forward pre-compensation: the equilibrium path whose filtered tip follows a path.

        Least squares, starting settled, with a small penalty on second differences (the
        exact inverse of a sampled filter rings at the Nyquist frequency).

        Parameters
        ----------
        t_s : array_like
            Uniform times (N,), s, N >= 3; the equilibrium is linear between them.
        p_des : array_like
            The desired tip path (N, d), m.
        smoothing : float
            Weight of the second-difference penalty (dimensionless).

        Returns
        -------
        numpy.ndarray
            The equilibrium path (N, d), m.
        """
        t, y = np.asarray(t_s, float), np.asarray(p_des, float)
        if y.ndim != 2 or len(t) != len(y) or len(t) < 3:
            raise InputError(f"need N >= 3 times and an (N, d) path, got {t.shape} and {y.shape}")
        n = len(t)
        M = self.response(t, np.eye(n), t)  # column j: the tip's response to knot j's equilibrium
        D = np.diff(np.eye(n), 2, axis=0)
        A = np.vstack([M, np.sqrt(smoothing) * D])
        b = np.vstack([y, np.zeros((n - 2, y.shape[1]))])
        return np.linalg.lstsq(A, b, rcond=None)[0]

    # ----------------------------------------------------------------- files
    def save(self, path: str | Path, **extra) -> None:
        """Write the model as ``.npz`` atomically.

        Parameters
        ----------
        path : str or pathlib.Path
            The file to write.
        **extra
            JSON-able metadata to store with it (e.g. robot and rig).
        """
        from lab.files import code_version

        meta = {
            "format_version": FORMAT_VERSION,
            "kind": KIND,
            "model": "relaxation",
            "n_modes": self.n_modes,
            "noise_sigma_m": None if not np.isfinite(self.noise_sigma_m) else float(self.noise_sigma_m),
            "units": {"tau_s": "s", "noise_sigma_m": "m"},
            "info": self.info,
            **extra,
            "code_version": code_version(),
        }
        with atomic_open(path, "wb") as fh:
            np.savez(
                fh,
                tau_s=self.tau_s,
                weight=self.weight,
                metadata=np.array(json.dumps(meta, default=json_default, allow_nan=False)),
            )


def load_relaxation(path: str | Path) -> Relaxation:
    """Read a dynamic model written by :meth:`Relaxation.save`.

    Parameters
    ----------
    path : str or pathlib.Path
        The ``.npz`` file.

    Returns
    -------
    Relaxation
        The model, with its noise and notes.

    Raises
    ------
    DynamicsFileError
        Naming the problem: a missing or corrupt file, another kind or a newer format.
    """
    path = Path(path)
    if not path.is_file():
        raise DynamicsFileError(f"{path}: no such dynamic-model file")
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["metadata"]))
            tau, w = np.array(z["tau_s"]), np.array(z["weight"])
    except (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile, json.JSONDecodeError) as err:
        raise DynamicsFileError(f"{path}: not a readable dynamic-model file ({err or type(err).__name__})") from None
    if not isinstance(meta, dict):
        raise DynamicsFileError(f"{path}: metadata must be a JSON object, got {type(meta).__name__}")
    if meta.get("kind") != KIND:
        raise DynamicsFileError(f"{path}: kind is {meta.get('kind')!r}, expected {KIND!r}")
    version = meta.get("format_version", 0)
    if isinstance(version, bool) or not isinstance(version, int):
        raise DynamicsFileError(f"{path}: format_version must be an integer, got {version!r}")
    if version > FORMAT_VERSION:
        raise DynamicsFileError(f"{path}: format_version {version} is newer than {FORMAT_VERSION}")
    noise, info = meta.get("noise_sigma_m"), meta.get("info", {})
    if noise is not None and (isinstance(noise, bool) or not isinstance(noise, (int, float))):
        raise DynamicsFileError(f"{path}: noise_sigma_m must be a number, got {noise!r}")
    if not isinstance(info, dict):
        raise DynamicsFileError(f"{path}: info must be a JSON object, got {type(info).__name__}")
    try:
        return Relaxation(tau, w, float("nan") if noise is None else float(noise), info)
    except InputError as err:
        raise DynamicsFileError(f"{path}: {err}") from err
