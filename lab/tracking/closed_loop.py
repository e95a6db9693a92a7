"""Closed-loop trajectory tracking: motion-capture feedback through the model's Jacobian.

Open loop (:mod:`lab.tracking.track`) sends the IK's commands once; with the tip measured, each command
is corrected by a damped Gauss-Newton step through the learned model's tip Jacobian
``J = dy/du`` (3, m) m/rad, kept inside the allowed commands and shortened to at most
``max_step_rad`` per motor (:func:`correct_command`). A measurement (:func:`measure_tip`)
averages the valid motion-capture frames of a window after the tip settled; too few valid
frames skip that correction. Two schedules (:func:`run_closed_loop`): ``"ilc"``, iterative
learning control over whole passes of the trajectory, and ``"feedback"``, settle-measure-
correct at each target. The settings are a :class:`Correction`. The derivation, the gain's
margin and the measured behaviour: ``docs/design/tracking.md``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from lab.capture.protocol import Protocol, Sample, measure
from lab.control.command_set import CommandSet
from lab.control.ik import IKSolver, check_targets
from lab.errors import InputError
from lab.rig.base import Rig
from lab.specs import Spec, at_most, finite, option, positive, positive_int
from lab.tracking.track import TRACK_PROTOCOL, TrackResult, run_info

__all__ = [
    "MODES",
    "DEFAULT_GAIN",
    "MAX_PASSES",
    "Correction",
    "TipMeasurement",
    "check_passes",
    "tip_from_frames",
    "measure_tip",
    "damped_pinv",
    "correct_command",
    "run_closed_loop",
]

MODES = ("ilc", "feedback")
#: Correction gain alpha (dimensionless): docs/design/tracking.md.
DEFAULT_GAIN = 0.9
#: The most passes of a closed-loop run: ILC settles in a few, and each pass measures every target again.
MAX_PASSES = 100
#: ``passes`` is a whole number in [1, MAX_PASSES].
check_passes = at_most(MAX_PASSES, positive_int)


def _open_interval(lo: float, hi: float, what: str = ""):
    def check(v):
        return None if finite(v) is None and lo < v < hi else f"must lie in ({lo:g}, {hi:g}){what}"

    return check


def _fraction(v) -> str | None:
    return None if positive(v) is None and v <= 1 else "must lie in (0, 1]"


@dataclass(frozen=True)
class Correction(Spec):
    """Settings of the correction (SI units; docs/design/tracking.md). ``gain`` alpha in
    (0, 2) (the flag ``--gain``); ``damping``: lambda / sigma_max(J); ``max_step_rad``: largest
    change of any motor per correction, rad; ``window_s``: averaging window after settling, s;
    ``min_valid_fraction``: share of that window's frames that must be valid for a correction;
    ``max_window_s``: how long the window may grow to collect them, s.

    Attributes
    ----------
    gain : float
        Correction gain alpha, in (0, 2).
    damping : float
        Damping lambda as a fraction of J's largest singular value, in (0, 1).
    max_step_rad : float
        Largest change of any motor per correction, rad.
    window_s : float
        Averaging window after settling, s.
    min_valid_fraction : float
        Share of the window's frames that must be valid, in (0, 1].
    max_window_s : float
        Longest the window may grow, s (>= ``window_s``).
    """

    gain: float = option(
        DEFAULT_GAIN,
        type=float,
        check=_open_interval(0, 2),
        help="with --closed-loop: correction gain alpha in (0, 2)",
    )
    damping: float = option(
        1e-2,
        cli=False,
        check=_open_interval(0, 1, " (a fraction of J's largest singular value)"),
        help="lambda / sigma_max(J)",
    )
    max_step_rad: float = option(
        0.3, cli=False, check=positive, unit="rad", help="largest change of a motor per correction, rad"
    )
    window_s: float = option(0.5, cli=False, check=positive, unit="s", help="averaging window after settling, s")
    min_valid_fraction: float = option(0.5, cli=False, check=_fraction, help="share of valid frames a correction needs")
    max_window_s: float = option(2.0, cli=False, check=positive, unit="s", help="longest the window may grow, s")

    def __post_init__(self):
        super().__post_init__()
        if not self.max_window_s >= self.window_s:
            raise InputError(f"max_window_s must be >= window_s, got {self.max_window_s!r} < {self.window_s!r}")


@dataclass
class TipMeasurement:
    """A settled tip: the protocol's ``sample``, ``p_tip_W`` (3,) m the mean of the window's
    valid frames (NaN when too few were valid), and the window's frame counts."""

    sample: Sample
    p_tip_W: np.ndarray
    n_valid: int
    n_frames: int

    @property
    def valid(self) -> bool:
        return bool(np.all(np.isfinite(self.p_tip_W)))

    @property
    def best_W(self) -> np.ndarray:
        """The window mean, else the protocol's last reading (3,) m: what the result reports."""
        return self.p_tip_W if self.valid else np.asarray(self.sample.p_tip_W, dtype=float)


def tip_from_frames(points_W, min_valid: int) -> tuple[np.ndarray, int]:
    """Mean of the finite rows of ``points_W`` (F, 3) m -- occluded (NaN) frames left out --
    and how many there were; (NaN (3,), count) when fewer than ``min_valid`` (>= 1)."""
    pts = np.asarray(points_W, dtype=float).reshape(-1, 3)
    ok = np.all(np.isfinite(pts), axis=1)
    n = int(ok.sum())
    if n < max(1, int(min_valid)):
        return np.full(3, np.nan), n
    return pts[ok].mean(axis=0), n


def measure_tip(rig: Rig, u_motor, protocol: Protocol = TRACK_PROTOCOL, correction: Correction = Correction()):
    """Send ``u_motor`` (m,) rad, wait by ``protocol``'s settle rule, then average the valid
    frames of ``correction.window_s``, grown by 0.1 s at a time up to ``max_window_s`` while
    fewer than ``min_valid_fraction`` of the window's frames are valid: a :class:`TipMeasurement`."""
    sample = measure(rig, u_motor, protocol)
    t_end = rig.now() + correction.max_window_s
    frames = rig.wait(correction.window_s)
    need = math.ceil(correction.min_valid_fraction * len(frames))

    def n_ok():
        return sum(f.valid for f in frames)

    while n_ok() < need and rig.now() < t_end - 1e-9:
        frames += rig.wait(min(0.1, t_end - rig.now()))
    p, n_valid = tip_from_frames([f.p_tip_W for f in frames], need)
    return TipMeasurement(sample, p, n_valid, len(frames))


def damped_pinv(J, damping: float = 1e-2) -> np.ndarray:
    """The damped pseudo-inverse ``(J^T J + lambda^2 I)^-1 J^T``, ``lambda = damping * sigma_max(J)``.

    Parameters
    ----------
    J : array_like
        Jacobian of the tip in the command, shape (3, m), m/rad.
    damping : float
        lambda as a fraction of J's largest singular value.

    Returns
    -------
    numpy.ndarray
        Shape (m, 3), rad/m.
    """
    J = np.asarray(J, dtype=float)
    lam2 = (damping * np.linalg.norm(J, 2)) ** 2
    return np.linalg.solve(J.T @ J + lam2 * np.eye(J.shape[1]), J.T)


def correct_command(
    commands: CommandSet, forward, u_motor, target_W, measured_W, correction: Correction = Correction()
) -> np.ndarray:
    """One correction of command ``u_motor`` (m,) rad (in ``commands``) towards ``target_W``
    (3,) m from the measured tip ``measured_W`` (3,) m, through ``forward.predict_and_jacobian``'s
    Jacobian at ``u_motor`` (docs/design/tracking.md). A non-finite measurement returns ``u_motor``
    unchanged: NaN never enters a correction. The answer is always in ``commands``.

    Parameters
    ----------
    commands : CommandSet
        The allowed commands (range and safety rules).
    forward : object
        The model, with ``predict_and_jacobian(u) -> (y (3,) m, J (3, m) m/rad)``.
    u_motor : array_like
        The current command, shape (m,), rad.
    target_W, measured_W : array_like
        Target and measured tip, shape (3,), m, frame W.
    correction : Correction
        Gain, damping and step limit.

    Returns
    -------
    numpy.ndarray
        The corrected command, shape (m,), rad, in ``commands``.
    """
    u = np.asarray(u_motor, dtype=float)
    measured = np.asarray(measured_W, dtype=float)
    if not np.all(np.isfinite(measured)):
        return u.copy()
    e = np.asarray(target_W, dtype=float) - measured
    J = np.asarray(forward.predict_and_jacobian(u)[1], dtype=float)
    if not np.all(np.isfinite(J)) or not np.any(J):  # no usable Jacobian (J = 0: every cable slack)
        return u.copy()
    H = J.T @ J + (correction.damping * np.linalg.norm(J, 2)) ** 2 * np.eye(len(u))
    x = commands.solve_qp(H, -(H @ u + correction.gain * J.T @ e), x0=u)
    du = x - u
    biggest = np.max(np.abs(du))
    if biggest > correction.max_step_rad:
        du *= correction.max_step_rad / biggest  # along the segment from u to x: still in C
    return commands.project(u + du, x0=u)  # a no-op unless rounding crossed a face


def run_closed_loop(
    rig: Rig,
    solver: IKSolver,
    targets_W,
    *,
    mode: str = "ilc",
    passes: int = 3,
    correction: Correction = Correction(),
    name: str = "custom",
    protocol: Protocol = TRACK_PROTOCOL,
    u0=None,
    progress=None,
    on_point=None,
) -> TrackResult:
    """Track ``targets_W`` (N, 3) m on ``rig`` with ``passes`` (>= 1) runs: pass 0 the open-loop
    IK commands of ``solver``, each later one corrected (``mode`` "ilc" or "feedback", module
    docs/design/tracking.md) through ``solver.forward``'s Jacobian. ``progress(done, total)`` after each
    measurement; ``on_point(i, target_W, u_motor, sample)`` with each (e.g.
    :meth:`.track.PointLog.append`). Returns the final pass as a :class:`TrackResult` with
    ``passes`` and ``info["closed_loop"]``; the rig is left open.

    Parameters
    ----------
    rig : Rig
        The robot.
    solver : IKSolver
        The IK on the model; its ``forward`` needs a Jacobian.
    targets_W : array_like
        Targets, shape (N, 3), m, frame W.
    mode : str
        ``"ilc"`` (pass by pass) or ``"feedback"`` (point by point).
    passes : int
        Runs, 1 to :data:`MAX_PASSES`.
    correction : Correction
        The correction's settings.
    name : str
        The trajectory's name in the result.
    protocol : Protocol
        How each point is settled and read.
    u0 : array_like, optional
        Warm start of the first IK solve, shape (m,), rad.
    progress : callable, optional
        ``progress(done, total)`` after each measurement.
    on_point : callable, optional
        ``on_point(i, target_W, u_motor, sample)`` with each measurement.

    Returns
    -------
    TrackResult
        The final pass, with one summary per pass in ``passes``.
    """
    if mode not in MODES:
        raise InputError(f"closed-loop mode must be one of {MODES}, got {mode!r}")
    if problem := check_passes(passes):
        raise InputError(f"passes {problem}, got {passes!r}")
    if not getattr(solver.forward, "has_jacobian", True) or not callable(
        getattr(solver.forward, "predict_and_jacobian", None)
    ):
        raise InputError("closed-loop correction needs the model's Jacobian, and this model has none")
    targets = np.atleast_2d(check_targets(targets_W))
    if solver.commands.n != rig.robot.n_inputs:
        raise InputError(
            f"the IK solves for {solver.commands.n} motors but robot {rig.robot.name} has {rig.robot.n_inputs}"
        )
    n, passes = len(targets), int(passes)
    t0 = time.perf_counter()
    plan = solver.follow(targets, u0)
    t_ik = time.perf_counter() - t0
    U = np.array(plan.u_motor, dtype=float)  # (N, m): each target's current command
    sent = np.empty((passes, n, U.shape[1]))  # what each pass sent and measured
    got = np.empty((passes, n, 3))
    settled, waits = np.zeros((passes, n), bool), np.zeros((passes, n))
    skipped = np.zeros((passes, n), bool)  # correction after this measurement skipped (NaN)
    done, total = 0, passes * n

    def visit(k, i):
        nonlocal done
        m = measure_tip(rig, U[i], protocol, correction)
        sent[k, i], got[k, i] = U[i], m.best_W
        settled[k, i], waits[k, i] = m.sample.settled, m.sample.t_done_s - m.sample.t_command_s
        if on_point is not None:
            on_point(i, targets[i], U[i], m.sample)
        done += 1
        if progress is not None:
            progress(done, total)
        if k < passes - 1:
            skipped[k, i] = not m.valid
            U[i] = correct_command(solver.commands, solver.forward, U[i], targets[i], m.p_tip_W, correction)

    t1 = time.perf_counter()
    if mode == "ilc":
        for k in range(passes):
            for i in range(n):
                visit(k, i)
    else:
        for i in range(n):
            for k in range(passes):
                visit(k, i)
    t_rig = time.perf_counter() - t1
    t = {"ik_total_s": t_ik, "rig_wall_s": t_rig, "total_s": time.perf_counter() - t0}
    info = run_info(rig, solver, plan, protocol)
    info["closed_loop"] = {"mode": mode, "passes": passes, **correction.as_dict(), "n_skipped": int(skipped.sum())}
    info["closed_loop"]["achieved"] = "mean of the valid frames of window_s after settling (else the last reading)"
    return _result(solver, plan, name, info, targets, sent, got, settled, waits, skipped, t)


def _result(solver, plan, name, info, targets, sent, got, settled, waits, skipped, t):
    """The final pass as a TrackResult with the per-pass summaries."""
    errors = np.linalg.norm(got - targets, axis=2)  # (passes, N) m
    passes = [
        {
            "pass": k,
            "mean_error_m": float(errors[k].mean()),
            "max_error_m": float(errors[k].max()),
            "commands": sent[k],
            "achieved": got[k],
            "n_skipped": int(skipped[k].sum()),
            "n_not_settled": int((~settled[k]).sum()),
        }
        for k in range(len(sent))
    ]
    timings = {
        "ik_total_s": t["ik_total_s"],
        "ik_per_target_mean_s": float(np.mean(plan.time_s)),
        "ik_per_target_median_s": float(np.median(plan.time_s)),
        "ik_per_target_max_s": float(np.max(plan.time_s)),
        "rig_wall_s": t["rig_wall_s"],
        "settle_mean_s": float(np.mean(waits[-1])),
        "total_s": t["total_s"],
    }
    final = sent[-1]
    return TrackResult(
        name,
        targets,
        final,
        got[-1],
        np.array([solver.forward.predict_and_jacobian(u)[0] for u in final], dtype=float),
        plan.residual_m,
        plan.reachable,
        plan.iterations,
        settled[-1],
        waits[-1],
        timings,
        info,
        plan.uncertain,
        plan.spread_m,
        passes=passes,
    )
