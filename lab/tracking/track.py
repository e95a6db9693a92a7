"""Open-loop trajectory following on a rig (Section II-D, V-A) and its result file.

:func:`run_trajectory` does what the paper does for Table I and Figures 3-4:

1. IK for every target, warm-started along the trajectory (:meth:`lab.control.ik.IKSolver.follow`),
   through the learned model or, for Soft IK, the FEM;
2. send each command to the rig in turn, wait until the tip has settled and record where
   it is -- the capture protocol's :func:`lab.rig.protocol.measure` (the paper's settle rule
   of Section III) without its hysteresis reset, since the trajectory is followed
   continuously;
3. errors ``|achieved - target|`` (m) in 3-D, their mean (Table I) and maximum.

The result file (:func:`write_result`, JSON, atomic) is a public contract. Keys:

* ``targets``, ``achieved``: (N, 3) tip positions, m, frame W;
* ``commands``: (N, m) motor angles, rad;
* ``errors_m`` (N,), ``mean_error_m``, ``max_error_m``: Euclidean distance target-achieved, m;
* ``timings``: seconds -- ``ik_total_s``, ``ik_per_target_mean_s``, ``..._median_s``,
  ``..._max_s`` (wall clock), ``rig_wall_s`` (wall clock spent sending and waiting),
  ``settle_mean_s`` (rig clock from command to record, per point), ``total_s``;
* extras: ``predicted`` (N, 3) m (the forward map at the commands), ``ik_residual_m`` (N,),
  ``reachable`` (N,), ``ik_iterations`` (N,), ``settled`` (N,), ``settle_wait_s`` (N,),
  ``n_unreachable``, ``n_not_settled``, ``trajectory``, ``info`` (rig, robot, solver,
  model, command line, code version, date), ``format_version``, ``kind``;
* ``uncertain`` (N,) bool: the model's predicted spread at the command exceeds
  ``info.solver.max_spread_m`` (all false for a model without a spread), ``predicted_spread_m``
  (N,) m (null without a spread); ``info.n_uncertain`` counts them. ``info.solver`` holds the
  regularisation the IK applied: ``reg_weight``/``posture_weight`` the weights of every
  point's solve, ``restart_weight`` that of a restart after a miss, ``..._setting`` what was
  asked ("auto" or the number), ``regularisation`` in words, and ``ik`` the restart counts
  (:mod:`lab.control.follow`).

Closed-loop runs (:mod:`lab.tracking.closed_loop`) write the same keys for their final pass,
plus ``passes``: one dict per pass (``pass``, ``mean_error_m``, ``max_error_m``, ``commands``
(N, m) rad, ``achieved`` (N, 3) m, ``n_skipped``, ...) and ``info.closed_loop``; files
without ``passes`` (open loop) read as before.

Not-a-number values are written as JSON ``null``.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lab.control.ik import IKSolver, check_targets
from lab.errors import InputError
from lab.files import atomic_write_text, code_version
from lab.rig.base import Rig
from lab.rig.protocol import Protocol, measure

#: How each trajectory point is recorded: the capture protocol without the reset.
TRACK_PROTOCOL = Protocol(reset=False)

FORMAT_VERSION = 1
KIND = "lab.track"
REQUIRED_KEYS = ("targets", "commands", "achieved", "errors_m", "mean_error_m", "max_error_m", "timings")


class TrackResultError(InputError):
    """A track result file is missing, corrupt, or lacks required keys."""


@dataclass
class TrackResult:
    """One trajectory run. Arrays: ``targets_W``, ``achieved_W``, ``predicted_W`` (N, 3) m;
    ``commands`` (N, m) rad; ``ik_residual_m``, ``settle_wait_s`` (N,); ``reachable``,
    ``settled`` (N,) bool; ``ik_iterations`` (N,). ``timings`` in seconds, ``info`` free-form;
    ``uncertain`` (N,) bool and ``predicted_spread_m`` (N,) m (NaN without a spread)."""

    trajectory: str
    targets_W: np.ndarray
    commands: np.ndarray
    achieved_W: np.ndarray
    predicted_W: np.ndarray
    ik_residual_m: np.ndarray
    reachable: np.ndarray
    ik_iterations: np.ndarray
    settled: np.ndarray
    settle_wait_s: np.ndarray
    timings: dict
    info: dict = field(default_factory=dict)
    uncertain: np.ndarray | None = None
    predicted_spread_m: np.ndarray | None = None
    passes: list[dict] | None = None  # closed loop: one dict per pass (module docstring)

    def __post_init__(self):
        n = len(self.targets_W)
        if self.uncertain is None:
            self.uncertain = np.zeros(n, dtype=bool)
        if self.predicted_spread_m is None:
            self.predicted_spread_m = np.full(n, np.nan)

    @property
    def errors_m(self) -> np.ndarray:
        """Euclidean distance from each target (N,) m."""
        return np.linalg.norm(self.achieved_W - self.targets_W, axis=1)

    @property
    def mean_error_m(self) -> float:
        """Mean distance from target (m): Table I's metric."""
        return float(np.mean(self.errors_m))

    @property
    def max_error_m(self) -> float:
        return float(np.max(self.errors_m))

    def to_json(self) -> dict:
        """The JSON document described in the module docstring."""
        return {
            "format_version": FORMAT_VERSION,
            "kind": KIND,
            "trajectory": self.trajectory,
            "units": {"positions": "m", "commands": "rad", "errors": "m", "timings": "s"},
            "targets": self.targets_W,
            "commands": self.commands,
            "achieved": self.achieved_W,
            "errors_m": self.errors_m,
            "mean_error_m": self.mean_error_m,
            "max_error_m": self.max_error_m,
            "timings": self.timings,
            "predicted": self.predicted_W,
            "ik_residual_m": self.ik_residual_m,
            "reachable": self.reachable,
            "ik_iterations": self.ik_iterations,
            "settled": self.settled,
            "settle_wait_s": self.settle_wait_s,
            "n_unreachable": int(np.sum(~self.reachable)),
            "n_not_settled": int(np.sum(~self.settled)),
            "uncertain": np.asarray(self.uncertain, dtype=bool),
            "predicted_spread_m": self.predicted_spread_m,
            "info": {**self.info, "n_uncertain": int(np.sum(self.uncertain))},
        } | ({} if self.passes is None else {"passes": self.passes})


class PointLog:
    """Append-only CSV of the points measured so far (one fsynced line each), so that a run
    that is interrupted or fails keeps what it measured. Columns: ``i, target_x, target_y,
    target_z`` (m), ``u0..u{m-1}`` (rad), ``x, y, z`` (m, achieved), ``settled``, ``wait_s``."""

    def __init__(self, path: str | Path, n_motors: int):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh = open(self.path, "w", newline="")
        cols = ["i", "target_x", "target_y", "target_z", *(f"u{j}" for j in range(n_motors)), "x", "y", "z"]
        self._write(",".join([*cols, "settled", "wait_s"]))

    def _write(self, line: str) -> None:
        self._fh.write(line + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def append(self, i: int, target_W, u_motor, sample) -> None:
        values = [*np.asarray(target_W, float), *np.asarray(u_motor, float), *np.asarray(sample.p_tip_W, float)]
        wait = sample.t_done_s - sample.t_command_s
        self._write(",".join([str(i), *(repr(float(v)) for v in values), str(int(sample.settled)), repr(wait)]))

    @property
    def n_points(self) -> int:
        """Points on disk (complete lines), whatever interrupted the writing."""
        return max(0, sum(1 for line in self.path.read_text().splitlines(keepends=True) if line.endswith("\n")) - 1)

    def close(self) -> None:
        self._fh.close()


def run_trajectory(
    rig: Rig,
    solver: IKSolver,
    targets_W,
    *,
    name: str = "custom",
    protocol: Protocol = TRACK_PROTOCOL,
    u0=None,
    progress=None,
    on_point=None,
) -> TrackResult:
    """IK for all ``targets_W`` (N, 3) m, then send each command to ``rig`` and record the
    settled tip with ``protocol`` (:class:`lab.rig.protocol.Protocol`, default
    :data:`TRACK_PROTOCOL`). ``u0``: warm start of the first IK solve (default: a cold start).
    ``progress(i, n)`` is called after each point, ``on_point(i, target_W, u_motor, sample)``
    with what was measured there (e.g. :meth:`PointLog.append`, so an interrupted run keeps
    its measurements). The rig is left open (the caller owns it)."""
    targets = np.atleast_2d(check_targets(targets_W))
    if solver.commands.n != rig.robot.n_cables:
        raise InputError(
            f"the IK solves for {solver.commands.n} motors but robot {rig.robot.name} has {rig.robot.n_cables}"
        )
    t0 = time.perf_counter()
    plan = solver.follow(targets, u0)
    t_ik = time.perf_counter() - t0
    achieved, settled, waits = np.empty_like(targets), np.zeros(len(targets), bool), np.zeros(len(targets))
    t1 = time.perf_counter()
    for i, u in enumerate(plan.u_motor):
        s = measure(rig, u, protocol)
        achieved[i], settled[i], waits[i] = s.p_tip_W, s.settled, s.t_done_s - s.t_command_s
        if on_point is not None:
            on_point(i, targets[i], u, s)
        if progress is not None:
            progress(i + 1, len(targets))
    t_rig = time.perf_counter() - t1
    timings = {
        "ik_total_s": t_ik,
        "ik_per_target_mean_s": float(np.mean(plan.time_s)),
        "ik_per_target_median_s": float(np.median(plan.time_s)),
        "ik_per_target_max_s": float(np.max(plan.time_s)),
        "rig_wall_s": t_rig,
        "settle_mean_s": float(np.mean(waits)),
        "total_s": time.perf_counter() - t0,
    }
    return TrackResult(
        name,
        targets,
        plan.u_motor,
        achieved,
        plan.p_pred_W,
        plan.residual_m,
        plan.reachable,
        plan.iterations,
        settled,
        waits,
        timings,
        run_info(rig, solver, plan, protocol),
        plan.uncertain,
        plan.spread_m,
    )


def run_info(rig: Rig, solver: IKSolver, plan, protocol: Protocol) -> dict:
    """The ``info`` of a result file: rig, robot, the IK's settings and what it did along
    ``plan`` (a :class:`lab.control.ik_result.TrajectoryIK`), the protocol, code version, date."""
    return {
        "rig": rig.describe(),
        "robot": rig.robot.name,
        "robot_sha256": rig.robot.sha256,
        "solver": {
            "method": solver.method,
            "tol_m": solver.tol_m,
            "reach_tol_m": solver.reach_tol_m,
            "reg_weight": plan.info["reg_weight"],
            "posture_weight": plan.info["posture_weight"],
            "u_posture": solver.u_posture.tolist(),
            "polish": solver.polish,
            "max_iter": solver.max_iter,
            "reg_weight_setting": _setting(solver.reg_weight_setting),
            "posture_weight_setting": _setting(solver.posture_weight_setting),
            "restart_weight": plan.info["restart_weight"],
            "regularisation": plan.info["regularisation"],
            "redundant": plan.info["redundant"],
            "spread_weight": solver.spread_weight,
            "max_spread_m": solver.max_spread_m,
            "notes": list(solver.notes),
            "ik": {k: plan.info[k] for k in ("slack_plateaus", "restarts", "recovered")},
        },
        "protocol": protocol.as_dict(),
        "code_version": code_version(),
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }


def _setting(weight) -> str | float:
    """A weight setting for the result file: "auto" for None, else the number."""
    return "auto" if weight is None else float(weight)


def _plain(obj):
    """numpy -> JSON types, NaN/inf -> None."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        return float(obj) if np.isfinite(obj) else None
    return obj


def write_result(path: str | Path, result: TrackResult, extra_info: dict | None = None) -> Path:
    """Write ``result`` as JSON to ``path`` (atomic); ``extra_info`` is merged into ``info``."""
    doc = result.to_json()
    doc["info"] = {**doc["info"], **(extra_info or {})}
    atomic_write_text(path, json.dumps(_plain(doc), indent=1, allow_nan=False) + "\n")
    return Path(path)


def read_result(path: str | Path) -> dict:
    """Load a result file (dict; arrays as numpy float arrays for the required keys);
    :class:`TrackResultError` for a missing or corrupt file or a missing key."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise TrackResultError(f"track result not found: {path}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise TrackResultError(f"{path}: corrupt track result ({err})") from None
    missing = [k for k in REQUIRED_KEYS if k not in doc]
    if not isinstance(doc, dict) or missing:
        raise TrackResultError(f"{path}: not a track result (missing {missing})")
    for key in ("targets", "commands", "achieved", "errors_m"):
        doc[key] = np.array(
            [np.nan if v is None else v for v in doc[key]]
            if key == "errors_m"
            else [[np.nan if v is None else v for v in row] for row in doc[key]],
            dtype=float,
        )
    return doc


def make_solver(
    robot,
    model=None,
    *,
    fem=None,
    method: str | None = None,
    reg_weight: float | None = None,
    posture_weight: float | None = None,
    seed_levels: int | None = None,
    spread_weight: float = 0.0,
    max_spread_m: float | None = None,
) -> IKSolver:
    """IK solver for ``robot`` through ``model`` (anything with ``predict_and_jacobian`` and a
    batched ``predict``; cold starts seeded from a ``seed_levels`` grid of its predictions)
    or, when ``model`` is None, Soft IK through the FEM ``fem`` (cold starts at the centre).

    ``method``: "lm", "gd" or "dfo"; None picks "lm", or the derivative-free "dfo"
    for a model with ``has_jacobian = False`` (the solver's ``notes`` say so; asking for
    "lm"/"gd" with such a model is an InputError). ``seed_levels`` defaults to 7 for up to
    three motors and 4 beyond (4^6 = 4096 seeds); ``reg_weight`` and ``posture_weight``
    (m^2/rad^2) as in :class:`lab.control.ik.IKSolver`, None (default) = automatic: no
    regulariser while the targets are reached, and on a redundant arm a missed point
    restarts regularised towards the posture, then polished (:mod:`lab.control.follow`);
    explicit weights regularise every point; 0 is off. ``spread_weight`` and
    ``max_spread_m`` (m): the spread penalty and flag (:mod:`lab.control.spread`)."""
    from lab.control.command_set import CommandSet
    from lab.control.ik import grid_seeds
    from lab.control.soft_ik import FEMForwardMap

    commands = CommandSet.from_robot(robot)
    kw = dict(reg_weight=reg_weight, posture_weight=posture_weight, spread_weight=spread_weight)
    if model is None:
        if fem is None:
            raise InputError("need a model or an FEM (Soft IK) to solve the IK")
        return IKSolver(FEMForwardMap(fem), commands, method or "lm", **kw)
    if callable(getattr(model, "command", None)):
        raise InputError(
            "this is a direct inverse model u = g(y): it has no forward map to solve the IK through; "
            "give a forward model (mlp, ensemble, gpr, knn, sklearn-mlp)"
        )
    if getattr(model, "n_u", robot.n_cables) != robot.n_cables or getattr(model, "n_y", 3) != 3:
        raise InputError(
            f"the model maps {model.n_u} inputs to {model.n_y} outputs, but robot "
            f"{robot.name} has {robot.n_cables} cables and a 3-D tip"
        )
    notes = []
    if not getattr(model, "has_jacobian", True):
        if method in ("lm", "gd"):
            raise InputError(
                f"method {method!r} needs the model's Jacobian, and this model has none: "
                "use the derivative-free 'dfo' (or leave the method out)"
            )
        if method is None:
            notes.append(
                "the model has no Jacobian: derivative-free IK (secant Levenberg-Marquardt with a compass poll)"
            )
        method = "dfo"
    if seed_levels is None:
        seed_levels = 7 if robot.n_cables <= 3 else 4
    solver = IKSolver(
        model,
        commands,
        method or "lm",
        seeds=grid_seeds(model, commands, seed_levels),
        max_spread_m=max_spread_m,
        **kw,
    )
    solver.notes.extend(notes)
    return solver
