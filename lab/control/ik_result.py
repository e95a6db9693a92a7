"""What the IK returns: one solve (:class:`IKResult`), a trajectory (:class:`TrajectoryIK`),
and the target check they share (re-exported by :mod:`lab.control.ik`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lab.errors import InputError


@dataclass
class IKResult:
    """One IK solve: command ``u_motor`` (m,) rad, predicted tip ``p_pred_W`` (3,) m, tip
    residual ``residual_m`` = |y(u) - y'| m, objective ``objective_m2``, how it stopped; the
    model's predicted spread ``spread_m`` (m, NaN without one) and whether it is ``uncertain``
    (spread above the solver's ``max_spread_m``)."""

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
    """IK along a trajectory of N targets: per-point arrays, the per-point results, and
    ``info``: the regularisation applied and the recovery counts (:mod:`lab.control.follow`)."""

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


def check_targets(targets) -> np.ndarray:
    """Targets as a float array (3,) or (N, 3) m; ValueError naming the problem otherwise."""
    t = np.asarray(targets, dtype=float)
    if t.shape[-1:] != (3,) or t.ndim not in (1, 2) or t.size == 0:
        raise InputError(f"targets must be (3,) or (N, 3) positions in metres, got shape {t.shape}")
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
