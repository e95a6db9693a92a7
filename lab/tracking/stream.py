"""Trajectories at speed: a periodic trajectory streamed continuously, open loop or pre-compensated.

:func:`run_trajectory` (:mod:`lab.tracking.track`) settles at every point; here the
trajectory is commanded as a motion of period ``T``, and the foam's lag
(:class:`~lab.dynamics.relaxation.Relaxation`) makes a quasi-static open loop trail behind
the target and shrink the shape. :func:`stream_trajectory` sends knots at a fixed command
rate after a settled lead-in -- the IK of the target path (open loop) or of the path the
inverted filter says the equilibrium must take (feed-forward) -- records every
motion-capture frame, and scores the last period. Its settings are a :class:`StreamSpec`,
bounded so that a run always ends. The result (:class:`StreamResult`) is a track result
with the streamed keys; the timing rules, the steps and the key list are in
``docs/design/tracking.md``.
"""

from __future__ import annotations

import datetime as _dt
import time
from dataclasses import dataclass

import numpy as np

from lab.capture.pace import MIN_RATE_FRACTION, frame_pace
from lab.control.ik import IKSolver, check_targets
from lab.dynamics.relaxation import Relaxation
from lab.errors import InputError, LabRuntimeError
from lab.files import code_version
from lab.rig.base import Rig
from lab.tracking.stream_spec import DEFAULT_COMMAND_RATE_HZ, DEFAULT_LEAD_IN_S, StreamSpec, default_n_periods
from lab.tracking.track import TrackResult

__all__ = [
    "StreamSpec",
    "StreamResult",
    "StreamPlan",
    "plan_stream",
    "stream_trajectory",
    "target_at",
    "default_n_periods",
    "DEFAULT_COMMAND_RATE_HZ",
    "DEFAULT_LEAD_IN_S",
    "LATE_COMMAND_FRACTION_ALLOWED",
]

#: The most commands of a streamed run that may go out late (more than one command period
#: after their time) for its result to mean anything: beyond, the rig followed another path
#: than the one planned, and the error would score the machine's load, not the robot.
LATE_COMMAND_FRACTION_ALLOWED = 0.1


def target_at(targets_W, period_s: float, t_s) -> np.ndarray:
    """The target (n, 3) m at times ``t_s`` (n,) s on a closed path through ``targets_W``
    (N, 3) m, point ``i`` at ``i T / N``, linear in between, repeating every ``period_s``."""
    p = np.asarray(targets_W, float)
    n = len(p)
    phase = np.mod(np.asarray(t_s, float) / period_s, 1.0) * n
    i = np.minimum(np.floor(phase).astype(int), n - 1)
    frac = (phase - i)[..., None]
    return p[i] * (1 - frac) + p[(i + 1) % n] * frac


@dataclass
class StreamPlan:
    """Knots of a streamed run: times ``t_s`` (K,) s from the start of the motion, desired
    tips ``p_des_W`` and equilibria ``p_in_W`` (K, 3) m, commands ``u_motor`` (K, m) rad and
    the model's tips there ``p_pred_W`` (K, 3) m, ``reachable`` (K,), ``ik_residual_m`` (K,),
    ``ik_iterations`` (K,); ``timings`` s.

    Attributes
    ----------
    t_s : numpy.ndarray
        Knot times from the start of the motion, shape (K,), s.
    p_des_W, p_in_W, p_pred_W : numpy.ndarray
        Desired tips, the equilibria commanded for them and the model's tips, shape (K, 3), m.
    u_motor : numpy.ndarray
        Commands, shape (K, m), rad.
    reachable : numpy.ndarray
        Per knot, shape (K,), bool.
    ik_residual_m : numpy.ndarray
        The IK's residual, shape (K,), m.
    ik_iterations : numpy.ndarray
        IK iterations per knot, shape (K,), int.
    timings : dict
        Wall times of the inversion and the IK, s.
    """

    t_s: np.ndarray
    p_des_W: np.ndarray
    p_in_W: np.ndarray
    u_motor: np.ndarray
    p_pred_W: np.ndarray
    reachable: np.ndarray
    ik_residual_m: np.ndarray
    ik_iterations: np.ndarray
    timings: dict

    @property
    def max_motor_speed_rad_s(self) -> float:
        """The fastest a motor must turn between knots, rad/s."""
        dt = np.diff(self.t_s)[:, None]
        return float(np.max(np.abs(np.diff(self.u_motor, axis=0)) / dt)) if len(dt) else 0.0


def plan_stream(
    solver: IKSolver,
    targets_W,
    period_s: float,
    *,
    relax: Relaxation | None = None,
    n_periods: int | None = None,
    command_rate_hz: float = DEFAULT_COMMAND_RATE_HZ,
    smoothing: float = 1e-3,
) -> StreamPlan:
    """The knots of a streamed run (docs/design/tracking.md, steps 2-4): open loop without
    ``relax``, feed-forward through ``relax.invert(..., smoothing)`` with it. The settings
    are checked as a :class:`StreamSpec` (InputError)."""
    targets = np.atleast_2d(check_targets(targets_W))
    spec = StreamSpec(period_s, n_periods, command_rate_hz=command_rate_hz, smoothing=smoothing)
    period_s, rate, n_knots = float(period_s), float(command_rate_hz), spec.n_knots
    if len(targets) < 3:
        raise InputError(f"a streamed trajectory needs at least 3 points along its period, got {len(targets)}")
    t = np.arange(n_knots) / rate
    p_des = target_at(targets, period_s, t)
    t0 = time.perf_counter()
    p_in = p_des if relax is None else relax.invert(t, p_des, smoothing)
    t_invert = time.perf_counter() - t0
    plan = solver.follow(p_in, None)
    timings = {
        "invert_s": t_invert,
        "ik_total_s": time.perf_counter() - t0 - t_invert,
        "ik_per_target_mean_s": float(np.mean(plan.time_s)),
        "ik_per_target_median_s": float(np.median(plan.time_s)),
        "ik_per_target_max_s": float(np.max(plan.time_s)),
    }
    return StreamPlan(
        t, p_des, p_in, plan.u_motor, plan.p_pred_W, plan.reachable, plan.residual_m, plan.iterations, timings
    )


@dataclass
class StreamResult(TrackResult):
    """A streamed run (docs/design/tracking.md): the rows of :class:`TrackResult` are the valid
    frames of the last period; ``t_s`` (N,) s their times since its start.

    Attributes
    ----------
    mode : str
        ``"open-loop"`` or ``"feed-forward"`` (through a relaxation filter).
    period_s : float
        The trajectory's period, s.
    n_periods : int
        Periods streamed.
    command_rate_hz : float
        Commands per second, Hz.
    lead_in_s : float
        Settling at the first command, s.
    t_s : numpy.ndarray or None
        Times of the rows since the last period's start, shape (N,), s.
    dynamic_model : dict or None
        The relaxation filter fed forward through (``tau_s``, ``weight``, ``noise_sigma_m``).
    knots : StreamPlan or None
        The commanded knots.
    """

    mode: str = "open-loop"
    period_s: float = float("nan")
    n_periods: int = 0
    command_rate_hz: float = DEFAULT_COMMAND_RATE_HZ
    lead_in_s: float = DEFAULT_LEAD_IN_S
    t_s: np.ndarray | None = None
    dynamic_model: dict | None = None
    knots: StreamPlan | None = None

    def to_json(self) -> dict:
        """The JSON document of the result file: :meth:`TrackResult.to_json` and the stream's fields.

        Returns
        -------
        dict
            The document, with ``mode``, ``period_s`` (s), ``t_s`` (N,) s and ``knots``.
        """
        doc = super().to_json()
        k = self.knots
        doc.update(
            mode=self.mode,
            period_s=self.period_s,
            n_periods=self.n_periods,
            command_rate_hz=self.command_rate_hz,
            lead_in_s=self.lead_in_s,
            t_s=self.t_s,
            dynamic_model=self.dynamic_model,
            knots=None
            if k is None
            else {
                "t_s": k.t_s,
                "p_des": k.p_des_W,
                "p_in": k.p_in_W,
                "commands": k.u_motor,
                "predicted": k.p_pred_W,
                "reachable": k.reachable,
                "max_motor_speed_rad_s": k.max_motor_speed_rad_s,
            },
        )
        return doc


def stream_trajectory(
    rig: Rig,
    solver: IKSolver,
    targets_W,
    period_s: float,
    *,
    relax: Relaxation | None = None,
    n_periods: int | None = None,
    command_rate_hz: float = DEFAULT_COMMAND_RATE_HZ,
    lead_in_s: float = DEFAULT_LEAD_IN_S,
    smoothing: float = 1e-3,
    name: str = "custom",
    progress=None,
) -> StreamResult:
    """Stream ``targets_W`` (N, 3) m, one period of ``period_s`` s, on ``rig``
    (docs/design/tracking.md): open loop, or feed-forward through ``relax``. The settings are checked as a
    :class:`StreamSpec` (InputError). ``progress(k, K)`` after each command. The rig is left
    open (the caller owns it).

    Parameters
    ----------
    rig : Rig
        The robot.
    solver : IKSolver
        The IK on the model.
    targets_W : array_like
        Points along one period, shape (N, 3), m, frame W (N >= 3).
    period_s : float
        The period, s.
    relax : Relaxation, optional
        The foam's relaxation filter to feed forward through (default: open loop).
    n_periods : int, optional
        Periods streamed (default :func:`default_n_periods`).
    command_rate_hz : float
        Commands per second, Hz.
    lead_in_s : float
        Settling at the first command, s.
    smoothing : float
        Smoothing of the filter's inversion.
    name : str
        The trajectory's name in the result.
    progress : callable, optional
        ``progress(k, K)`` after each command.

    Returns
    -------
    StreamResult
        The valid frames of the last period against the path's targets at their times.
    """
    if solver.commands.n != rig.robot.n_inputs:
        raise InputError(
            f"the IK solves for {solver.commands.n} motors but robot {rig.robot.name} has {rig.robot.n_inputs}"
        )
    n_periods = StreamSpec(period_s, n_periods, lead_in_s, command_rate_hz, smoothing).periods
    t_start = time.perf_counter()
    plan = plan_stream(
        solver, targets_W, period_s, relax=relax, n_periods=n_periods, command_rate_hz=command_rate_hz,
        smoothing=smoothing,
    )  # fmt: skip
    t_rig = time.perf_counter()
    t_frames, p_frames, k_frames, lateness = _run(rig, plan, lead_in_s, progress)
    t_rig = time.perf_counter() - t_rig
    # the last period, valid frames only
    in_last = (t_frames >= plan.t_s[-1] - period_s - 1e-9) & (t_frames < plan.t_s[-1] - 1e-9)
    pace = _check_pace(t_frames[in_last], rig.frame_rate_hz, float(period_s), lateness, float(command_rate_hz))
    last = in_last & np.all(np.isfinite(p_frames), axis=1)
    if not np.any(last):
        raise LabRuntimeError("no valid motion-capture frame in the last period: nothing to compare")
    tf, pf, kf = t_frames[last], p_frames[last], k_frames[last]
    targets = target_at(np.atleast_2d(targets_W), period_s, tf)
    n = len(tf)
    timings = {
        **plan.timings,
        "rig_wall_s": t_rig,
        "settle_mean_s": 0.0,
        "total_s": time.perf_counter() - t_start,
        "rig_clock_s": float(lead_in_s + plan.t_s[-1]),
    }
    info = {
        "rig": rig.describe(),
        "robot": rig.robot.name,
        "robot_sha256": rig.robot.sha256,
        "solver": {k: getattr(solver.config, k) for k in ("method", "tol_m", "reach_tol_m")},
        "smoothing": smoothing,
        "n_frames": int(len(t_frames)),
        "n_frames_last_period": int(np.sum(in_last)),
        "n_knots_unreachable": int(np.sum(~plan.reachable)),
        "pace": pace,
        "code_version": code_version(),
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }
    return StreamResult(
        name,
        targets,
        plan.u_motor[kf],
        pf,
        plan.p_pred_W[kf],
        plan.ik_residual_m[kf],
        plan.reachable[kf],
        plan.ik_iterations[kf],
        np.zeros(n, bool),
        np.zeros(n),
        timings,
        info,
        mode="open-loop" if relax is None else "feed-forward",
        period_s=float(period_s),
        n_periods=n_periods,
        command_rate_hz=float(command_rate_hz),
        lead_in_s=float(lead_in_s),
        t_s=tf - (plan.t_s[-1] - period_s),
        dynamic_model=None
        if relax is None
        else {"tau_s": relax.tau_s, "weight": relax.weight, "noise_sigma_m": relax.noise_sigma_m},
        knots=plan,
    )


def _check_pace(t_last, frame_rate_hz: float, period_s: float, lateness, command_rate_hz: float) -> dict:
    """The stream's pace (:func:`lab.capture.pace.frame_pace` over the scored period, and how
    late its commands went out) for the result's ``info``; LabRuntimeError when the machine
    fell behind what a result needs: under half the frames of the scored period, or more than
    :data:`LATE_COMMAND_FRACTION_ALLOWED` of the commands sent a command period late or more."""
    pace = frame_pace(t_last, frame_rate_hz, span_s=period_s)
    late = int(np.sum(lateness > 1.0 / command_rate_hz))
    max_late = int(LATE_COMMAND_FRACTION_ALLOWED * len(lateness))
    if pace.behind or late > max_late:
        need = int(np.ceil(MIN_RATE_FRACTION * pace.expected_frames))
        raise LabRuntimeError(
            f"the machine fell behind: the stream {pace.missed()} in the scored period, and sent {late} of "
            f"{len(lateness)} commands a command period ({1 / command_rate_hz:.3f} s) late or more; a result needs "
            f"at least {need} frames and at most {max_late} late commands. Nothing was written: run again on a "
            "machine with less other work"
        )
    return {
        **pace.as_dict(),
        "n_commands_late": late,
        "max_command_lateness_s": float(np.max(lateness)) if len(lateness) else 0.0,
    }


def _run(rig: Rig, plan: StreamPlan, lead_in_s: float, progress=None):
    """Lead-in at knot 0, then knot k+1 sent at t_k; returns every frame after the lead-in:
    times (n,) s since the motion began, tips (n, 3) m (NaN: occluded), the knot in
    force (the latest sent), and how late each knot went out, (K-1,) s."""
    rig.send(plan.u_motor[0])
    rig.wait(lead_in_s)
    t0 = rig.now()
    ts, ps, ks = [], [], []
    n = len(plan.t_s)
    lateness = np.zeros(n - 1)
    for k in range(n - 1):
        lateness[k] = max(0.0, rig.now() - t0 - plan.t_s[k])
        rig.send(plan.u_motor[k + 1])
        t_next = t0 + plan.t_s[k + 1]
        while rig.now() < t_next - 1e-9:
            f = rig.next_frame()
            ts.append(f.t_s - t0)
            ps.append(f.p_tip_W)
            ks.append(k + 1)
        if progress is not None:
            progress(k + 1, n - 1)
    return np.asarray(ts), np.asarray(ps, float).reshape(-1, 3), np.asarray(ks, int), lateness
