"""Closed-loop trajectory tracking: motion-capture feedback through the model's Jacobian (issue 16).

Open-loop tracking (:mod:`.track`) sends the IK's commands once; what the model gets wrong
(a sim-trained model on the real robot, noise in the data, play, lag) stays in the error.
With the tip measured, each command is corrected by a Gauss-Newton step through the
learned model's tip Jacobian ``J = dy/du`` (3, m) m/rad at the command::

    u_new = argmin_{x in C}  |J (x - u) - alpha e|^2 + lambda^2 |x - u|^2,   e = target - measured

-- the damped pseudo-inverse step ``alpha J+ e`` (``J+ = (J^T J + lambda^2 I)^-1 J^T``) whenever
that lands in the allowed commands ``C`` (box ``[0, u_max]`` and the safety rule,
:class:`lab.control.command_set.CommandSet`), else the best step inside ``C`` in the tip's
metric (the same exact QP the IK's bounded LM step solves), so a target out of reach
converges to the nearest reachable point rather than to an arbitrary clipped command. The
step is then shortened to at most ``max_step_rad`` per motor (a glitch in the capture can
never throw the arm); ``C`` is convex and both ends lie in it, so every command sent stays
allowed. ``lambda = damping * sigma_max(J)`` keeps the step bounded near a singular ``J``.
With an exact Jacobian the error shrinks by ``1 - alpha`` per correction; with a Jacobian off
by a relative ``d`` roughly by ``|1 - alpha| + alpha d``: the default ``alpha = 0.9``
(:data:`DEFAULT_GAIN`) leaves margin for a model whose Jacobian is some tens of percent off
and for noise, which a gain below one also averages.

Measurement (:func:`measure_tip`): the capture protocol's settle rule (:data:`TRACK_PROTOCOL`,
no reset), then the mean of the *valid* frames of a further ``window_s`` (0.5 s: 60 frames,
noise down by ~8 from a single frame). NaN (occluded) frames are left out
(:func:`tip_from_frames`); while fewer than ``min_valid_fraction`` of the window's frames are
valid, the window grows (up to ``max_window_s``), so that a dropout delays a measurement
rather than losing it; still too few, the measurement is NaN, the correction of that target
is skipped (its command unchanged) and counted. A correction never sees a NaN:
:func:`correct_command` leaves the command alone.

Two schedules (:func:`run_closed_loop`):

* ``"ilc"`` -- iterative learning control: pass 0 sends the open-loop IK commands along the
  whole trajectory (no reset, as :func:`.track.run_trajectory`); after each pass every
  target's command is corrected from that pass's measurement, and the next pass runs the
  corrected commands. Errors that repeat from pass to pass (model error, the lag and play
  left by the path) are learnt away.
* ``"feedback"`` -- per target: settle, measure, correct, ``passes - 1`` times, then on to
  the next target. Pass ``k`` in the result is iteration ``k`` over all targets. Its later
  corrections are small, within the cables' play and beside the foam's creep: on the
  emulated robot it stops near 0.017 cm where ILC goes on to 0.007 cm (``data/README.md``).

``passes`` counts the runs including the open-loop pass 0; the result is a
:class:`.track.TrackResult` of the final pass (same file keys) with ``passes``: per pass
``mean_error_m``, ``max_error_m``, ``commands`` (N, m) rad, ``achieved`` (N, 3) m,
``n_skipped`` (corrections skipped after that pass) and ``n_not_settled``.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from lab.control.command_set import CommandSet
from lab.control.ik import IKSolver, check_targets
from lab.errors import InputError
from lab.rig.base import Rig
from lab.rig.protocol import Protocol, Sample, measure
from lab.tracking.track import TRACK_PROTOCOL, TrackResult, run_info

MODES = ("ilc", "feedback")
#: Correction gain alpha (dimensionless): see the module docstring.
DEFAULT_GAIN = 0.9


@dataclass(frozen=True)
class Correction:
    """Settings of the correction (SI units; module docstring). ``gain`` alpha in (0, 2);
    ``damping``: lambda / sigma_max(J); ``max_step_rad``: largest change of any motor per
    correction, rad; ``window_s``: averaging window after settling, s; ``min_valid_fraction``:
    share of that window's frames that must be valid for a correction; ``max_window_s``: how
    long the window may grow to collect them, s."""

    gain: float = DEFAULT_GAIN
    damping: float = 1e-2
    max_step_rad: float = 0.3
    window_s: float = 0.5
    min_valid_fraction: float = 0.5
    max_window_s: float = 2.0

    def __post_init__(self):
        if not (0 < self.gain < 2):
            raise InputError(f"the correction gain must lie in (0, 2), got {self.gain!r}")
        if not (0 < self.damping < 1):
            raise InputError(
                f"damping must lie in (0, 1) (a fraction of J's largest singular value), got {self.damping!r}"
            )
        if not self.max_window_s >= self.window_s:
            raise InputError(f"max_window_s must be >= window_s, got {self.max_window_s!r} < {self.window_s!r}")
        for name in ("max_step_rad", "window_s"):
            if not (getattr(self, name) > 0 and math.isfinite(getattr(self, name))):
                raise InputError(f"{name} must be a positive number, got {getattr(self, name)!r}")
        if not (0 < self.min_valid_fraction <= 1):
            raise InputError(f"min_valid_fraction must lie in (0, 1], got {self.min_valid_fraction!r}")

    def as_dict(self) -> dict:
        return asdict(self)


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
    """``(J^T J + lambda^2 I)^-1 J^T`` (m, 3) rad/m for ``J`` (3, m) m/rad, ``lambda = damping
    * sigma_max(J)``."""
    J = np.asarray(J, dtype=float)
    lam2 = (damping * np.linalg.norm(J, 2)) ** 2
    return np.linalg.solve(J.T @ J + lam2 * np.eye(J.shape[1]), J.T)


def correct_command(
    commands: CommandSet, forward, u_motor, target_W, measured_W, correction: Correction = Correction()
) -> np.ndarray:
    """One correction of command ``u_motor`` (m,) rad (in ``commands``) towards ``target_W``
    (3,) m from the measured tip ``measured_W`` (3,) m, through ``forward.predict_and_jacobian``'s
    Jacobian at ``u_motor`` (module docstring). A non-finite measurement returns ``u_motor``
    unchanged: NaN never enters a correction. The answer is always in ``commands``."""
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
    docstring) through ``solver.forward``'s Jacobian. ``progress(done, total)`` after each
    measurement; ``on_point(i, target_W, u_motor, sample)`` with each (e.g.
    :meth:`.track.PointLog.append`). Returns the final pass as a :class:`TrackResult` with
    ``passes`` and ``info["closed_loop"]``; the rig is left open."""
    if mode not in MODES:
        raise InputError(f"closed-loop mode must be one of {MODES}, got {mode!r}")
    if isinstance(passes, bool) or int(passes) != passes or passes < 1:
        raise InputError(f"passes must be an integer >= 1, got {passes!r}")
    if not getattr(solver.forward, "has_jacobian", True) or not callable(
        getattr(solver.forward, "predict_and_jacobian", None)
    ):
        raise InputError("closed-loop correction needs the model's Jacobian, and this model has none")
    targets = np.atleast_2d(check_targets(targets_W))
    if solver.commands.n != rig.robot.n_cables:
        raise InputError(
            f"the IK solves for {solver.commands.n} motors but robot {rig.robot.name} has {rig.robot.n_cables}"
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
