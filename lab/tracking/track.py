"""Open-loop trajectory following on a rig (Section II-D, V-A) and its result file.

:func:`run_trajectory` does what the paper does for Table I and Figures 3-4: the IK for
every target, warm-started along the trajectory (:meth:`lab.control.ik.IKSolver.follow`),
through the learned model or, for Soft IK, the FEM; then each command is sent to the rig in
turn and the settled tip recorded by the capture protocol's settle rule without its reset
(:data:`TRACK_PROTOCOL`: the trajectory is followed continuously); the errors are the 3-D
distances ``|achieved - target|`` (m), their mean (Table I) and maximum.

The result file (:func:`write_result`, JSON, atomic; :func:`read_result`) is a public
contract, also written by closed-loop and streamed runs: its keys are listed in
``docs/design/tracking.md`` ("The result file"). Not-a-number values are written as JSON
``null``.
"""

from __future__ import annotations

import datetime as _dt
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lab.capture.protocol import Protocol, measure
from lab.control.ik import IKSolver, check_targets
from lab.errors import InputError
from lab.files import atomic_write_text, code_version
from lab.rig.base import Rig

#: How each trajectory point is recorded: the capture protocol without the reset.
TRACK_PROTOCOL = Protocol(reset=False)

FORMAT_VERSION = 1
KIND = "lab.track"
REQUIRED_KEYS = ("targets", "commands", "achieved", "errors_m", "mean_error_m", "max_error_m", "timings")


class TrackResultError(InputError):
    """A track result file is missing, corrupt, or lacks required keys."""


@dataclass
class TrackResult:
    """One trajectory run, N targets on a robot with m motors.

    Attributes
    ----------
    trajectory : str
        The trajectory's name.
    targets_W, achieved_W, predicted_W : numpy.ndarray
        Targets, measured settled tips and the model's tips, shape (N, 3), m, frame W.
    commands : numpy.ndarray
        Motor angles sent, shape (N, m), rad.
    ik_residual_m : numpy.ndarray
        The IK's residual |f(u) - target|, shape (N,), m.
    reachable, settled : numpy.ndarray
        Per target, shape (N,), bool.
    ik_iterations : numpy.ndarray
        IK iterations per target, shape (N,), int.
    settle_wait_s : numpy.ndarray
        Time from command to settled, shape (N,), s.
    timings : dict
        Wall times, s.
    info : dict
        Free-form: rig, robot, solver settings, protocol, code version.
    uncertain : numpy.ndarray, optional
        Targets the model's spread flagged, shape (N,), bool (default all False).
    predicted_spread_m : numpy.ndarray, optional
        The model's spread at each command, shape (N,), m (NaN without a spread).
    passes : list of dict, optional
        Closed loop: one summary per pass.
    """

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
    passes: list[dict] | None = None  # closed loop: one dict per pass (docs/design/tracking.md)

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
        """The JSON document of the result file (docs/design/tracking.md).

        Returns
        -------
        dict
            Keys of :data:`REQUIRED_KEYS` and the rest of the result, arrays as numpy
            arrays (m, rad, s; :func:`write_result` makes them JSON).
        """
        return {
            "format_version": FORMAT_VERSION,
            "kind": KIND,
            "trajectory": self.trajectory,
            "units": {"positions": "m", "commands": self.info.get("input_units", "rad"), "errors": "m", "timings": "s"},
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
    settled tip with ``protocol`` (:class:`lab.capture.protocol.Protocol`, default
    :data:`TRACK_PROTOCOL`). ``u0``: warm start of the first IK solve (default: a cold start).
    ``progress(i, n)`` is called after each point, ``on_point(i, target_W, u_motor, sample)``
    with what was measured there (e.g. :meth:`lab.tracking.points.PointLog.append`, so an interrupted run keeps
    its measurements). The rig is left open (the caller owns it).

    Parameters
    ----------
    rig : Rig
        The robot (hardware, emulator or twin).
    solver : IKSolver
        The IK on the model (:class:`lab.control.IKSolver`).
    targets_W : array_like
        Targets, shape (N, 3), m, frame W.
    name : str
        The trajectory's name in the result.
    protocol : Protocol
        How each point is settled and read.
    u0 : array_like, optional
        Warm start of the first IK solve, shape (m,), rad.
    progress : callable, optional
        ``progress(i, n)`` after each point.
    on_point : callable, optional
        ``on_point(i, target_W, u_motor, sample)`` with each measurement.

    Returns
    -------
    TrackResult
        Commands, settled tips and errors of the N targets.
    """
    targets = np.atleast_2d(check_targets(targets_W))
    if solver.commands.n != rig.robot.n_inputs:
        raise InputError(
            f"the IK solves for {solver.commands.n} motors but robot {rig.robot.name} has {rig.robot.n_inputs}"
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
    cfg = solver.config
    return {
        "rig": rig.describe(),
        "robot": rig.robot.name,
        "robot_sha256": rig.robot.sha256,
        **({} if rig.robot.all_angle else {"input_units": list(rig.robot.input_units)}),
        "solver": {
            "method": cfg.method,
            "tol_m": cfg.tol_m,
            "reach_tol_m": cfg.reach_tol_m,
            "reg_weight": plan.info["reg_weight"],
            "posture_weight": plan.info["posture_weight"],
            "u_posture": solver.u_posture.tolist(),
            "polish": cfg.polish,
            "max_iter": cfg.max_iter,
            "reg_weight_setting": _setting(cfg.reg_weight),
            "posture_weight_setting": _setting(cfg.posture_weight),
            "restart_weight": plan.info["restart_weight"],
            "regularisation": plan.info["regularisation"],
            "redundant": plan.info["redundant"],
            "spread_weight": cfg.spread_weight,
            "max_spread_m": cfg.max_spread_m,
            "notes": list(solver.notes),
            "ik": {k: plan.info[k] for k in ("slack_plateaus", "restarts", "recovered")},
            **(
                {"markers": plan.info["markers"], "marker_offsets_m": plan.info["marker_offsets_m"]}
                if "markers" in plan.info
                else {}
            ),
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
    """Write ``result`` as JSON to ``path`` (atomic); ``extra_info`` is merged into ``info``.

    Parameters
    ----------
    path : str or Path
        The result file (``.json``).
    result : TrackResult
        The run.
    extra_info : dict, optional
        Merged into the file's ``info``.

    Returns
    -------
    Path
        ``path``.
    """
    doc = result.to_json()
    doc["info"] = {**doc["info"], **(extra_info or {})}
    atomic_write_text(path, json.dumps(_plain(doc), indent=1, allow_nan=False) + "\n")
    return Path(path)


def read_result(path: str | Path) -> dict:
    """Load a result file (dict; arrays as numpy float arrays for the required keys);
    :class:`TrackResultError` for a missing or corrupt file or a missing key.

    Parameters
    ----------
    path : str or Path
        A result file of :func:`write_result`.

    Returns
    -------
    dict
        The document; ``targets``, ``achieved`` (N, 3) m, ``commands`` (N, m) rad and
        ``errors_m`` (N,) m as float arrays (NaN for null).
    """
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
