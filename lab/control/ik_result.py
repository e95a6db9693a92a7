"""What the IK returns: one solve (:class:`IKResult`), a trajectory (:class:`TrajectoryIK`),
and the target check they share (re-exported by :mod:`lab.control.ik`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lab.errors import InputError


@dataclass
class IKResult:
    """One IK solve.

    Attributes
    ----------
    u_motor : numpy.ndarray
        The command (m,), rad.
    p_pred_W : numpy.ndarray
        The predicted tip (3,), m, frame W.
    residual_m : float
        Tip residual ``|y(u) - y'|`` (m).
    objective_m2 : float
        The objective at ``u_motor`` (m^2).
    reachable : bool
        Whether the residual is within the solver's ``reach_tol_m``.
    status : str
        How it stopped (e.g. "converged", "stationary", "max_iter").
    iterations, evaluations : int
        Iterations and forward-map evaluations spent.
    time_s : float
        Wall time (s).
    history_m : list of float
        The residual (m) after each iteration (when recorded).
    spread_m : float
        The model's predicted spread (m); NaN without one.
    uncertain : bool
        Whether the spread is above the solver's ``max_spread_m``.
    """

    u_motor: np.ndarray
    p_pred_W: np.ndarray
    residual_m: float
    objective_m2: float
    reachable: bool
    status: str
    iterations: int
    evaluations: int
    time_s: float
    history_m: list = field(default_factory=list, repr=False)  # residual after each iteration
    spread_m: float = float("nan")
    uncertain: bool = False


@dataclass
class TrajectoryIK:
    """IK along a trajectory of N targets.

    Attributes
    ----------
    targets_W : numpy.ndarray
        Targets (N, 3), m, frame W.
    u_motor : numpy.ndarray
        Commands (N, m), rad.
    p_pred_W : numpy.ndarray
        Forward map at ``u_motor`` (N, 3), m, frame W.
    residual_m : numpy.ndarray
        Tip residuals (N,), m.
    reachable : numpy.ndarray
        (N,) bool.
    iterations : numpy.ndarray
        (N,) int.
    time_s : numpy.ndarray
        Wall time per target (N,), s.
    results : list of IKResult
        The per-point results.
    uncertain : numpy.ndarray or None
        (N,) bool: predicted spread above ``max_spread_m``.
    spread_m : numpy.ndarray or None
        Predicted spread (N,), m; NaN without one.
    info : dict
        The regularisation applied and the recovery counts (:mod:`lab.control.follow`).
    """

    targets_W: np.ndarray  # (N, 3) m
    u_motor: np.ndarray  # (N, m) rad
    p_pred_W: np.ndarray  # (N, 3) m, forward map at u_motor
    residual_m: np.ndarray  # (N,) m
    reachable: np.ndarray  # (N,) bool
    iterations: np.ndarray  # (N,)
    time_s: np.ndarray  # (N,) s per target
    results: list = field(repr=False, default_factory=list)
    uncertain: np.ndarray | None = None  # (N,) bool: predicted spread above max_spread_m
    spread_m: np.ndarray | None = None  # (N,) m, NaN without a spread
    info: dict = field(default_factory=dict)


def check_targets(targets, width: int = 3) -> np.ndarray:
    """Targets as a float array; InputError naming the problem otherwise.

    Parameters
    ----------
    targets : array_like
        One target (w,) or N targets (N, w), m, frame W; finite.
    width : int
        w: 3 per marker the IK drives (3 for the tip alone).

    Returns
    -------
    numpy.ndarray
        The targets, (w,) or (N, w), float.
    """
    t = np.asarray(targets, dtype=float)
    if t.shape[-1:] != (width,) or t.ndim not in (1, 2) or t.size == 0:
        raise InputError(f"targets must be ({width},) or (N, {width}) positions in metres, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        bad = np.argwhere(~np.isfinite(np.atleast_2d(t)))[0, 0]
        raise InputError(f"target {bad} is not finite: {np.atleast_2d(t)[bad].tolist()} (NaN or inf)")
    return t


def count_work(result: IKResult, others) -> IKResult:
    """``result`` with the iterations, evaluations and time of the ``others`` solves added."""
    for other in others:
        result.iterations += other.iterations
        result.evaluations += other.evaluations
        result.time_s += other.time_s
    return result
