"""``track --rig none``: the IK's commands for a lab's own robot, from the learned model alone.

A lab whose robot has no rig driver here (no FEM, no ``hardware:`` configuration) still
wants the commands that put its tip on a path: :func:`solve_targets` solves the IK for each
target through the model, inside the box of commands the model was trained on
(:func:`lab.learn.history.data_bounds`; for a model trained on a shipped robot's data,
that robot's allowed commands too), and :func:`run_offline` writes the result JSON and
``OUT.commands.csv`` (:mod:`lab.tracking.solved_targets`: what the result says -- the IK
residual through the model, the model's spread, the command steps -- and why) for the lab
to send by its own means. Nothing is measured. ``run_offline`` follows the targets on a
smooth path (``IKConfig.smooth_path``): a redundant arm's commands stay on one branch of
answers instead of jumping across the box between neighbouring targets. A history model
(:mod:`lab.learn.history`) is solved target by target in file order, its past fixed to the
answers already sent (the first target with the robot resting at its command). The keys
are in docs/design/tracking.md ("Commands without a rig").
"""

from __future__ import annotations

import datetime as _dt
import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from lab.control.ik import IKConfig, IKSolver, check_forward
from lab.control.markers import forward_markers
from lab.control.spread import has_spread
from lab.control.trajectories import BUILTIN, SIX_CABLE, load_trajectory
from lab.description import load_robot, shipped_robots
from lab.errors import InputError
from lab.files import atomic_write_group, code_version
from lab.learn.history import at_rest, data_bounds, history_of, past_commands, with_past
from lab.learn.models import load_model
from lab.tracking.marker_targets import with_marker_offsets
from lab.tracking.solved_targets import SolvedTargets, check_commands_file, commands_path, spread_source
from lab.tracking.track import _plain

__all__ = ["solve_targets", "run_offline", "trained_robot"]


def trained_robot(model) -> str | None:
    """The shipped robot (e.g. "three-cable") whose data ``model`` was trained on, from its
    metadata (``training.data.robot``); None for any other data or none recorded."""
    data = ((getattr(model, "metadata", None) or {}).get("training") or {}).get("data") or {}
    name = data.get("robot") if isinstance(data, dict) else None
    return name if isinstance(name, str) and name in shipped_robots() else None


def solve_targets(model, targets_W, config: IKConfig | None = None, *, robot=None, bounds=None) -> dict:
    """IK for each target (N, 3) m through ``model``, inside ``robot``'s allowed commands
    and/or the box ``bounds`` = (lo (m,), hi (m,)) (:meth:`IKSolver.for_model`).

    An ordinary model: warm-started along the targets (:meth:`IKSolver.follow`). A history
    model (K > 0): target 0 through ``at_rest(model)``, target i through ``with_past(model,
    answers i-1, i-2, ... newest first)`` (fewer than K padded with the first answer), each
    warm-started from the previous answer. Returns a dict: ``commands`` (N, m),
    ``predicted`` (N, 3) m, ``reachable``, ``uncertain`` (N,) bool, ``spread_m`` (N,) m,
    ``iterations`` (N,), ``time_s`` (N,), ``solver`` (the first target's IKSolver),
    ``info`` (the follow info; restart counts summed over the targets).

    Parameters
    ----------
    model : object
        A forward model u -> tip (m), with or without history.
    targets_W : array_like
        Targets, shape (N, 3), m.
    config : IKConfig, optional
        The IK's settings (default: its defaults).
    robot : RobotDescription, optional
        Whose allowed commands (range, safety rules) the answers stay in.
    bounds : tuple of numpy.ndarray, optional
        The box (lo (m,), hi (m,)) in the training data's units.

    Returns
    -------
    dict
        The keys listed above.
    """
    targets = np.atleast_2d(np.asarray(targets_W, dtype=float))
    k = history_of(model)
    if k == 0:
        solver = with_marker_offsets(IKSolver.for_model(model, robot, config, bounds=bounds), model)
        plans = [solver.follow(targets)]
    else:
        if config is not None and config.markers != ("tip",):
            raise InputError(
                f"IKConfig.markers {','.join(config.markers)}: a model with history (K = {k}) drives the tip alone"
            )
        solver, plans = None, []
        for i, target in enumerate(targets):
            answers = np.array([p.u_motor[0] for p in plans])
            forward = at_rest(model) if i == 0 else with_past(model, past_commands(answers, k))
            step = IKSolver.for_model(forward, robot, config, bounds=bounds)
            solver = solver or step
            plans.append(step.follow(target[None], None if i == 0 else answers[-1]))
    cat = lambda name: np.concatenate([np.atleast_1d(getattr(p, name)) for p in plans])  # noqa: E731
    info = dict(plans[0].info)
    for key in ("slack_plateaus", "restarts", "recovered"):
        info[key] = int(sum(p.info[key] for p in plans))
    return {
        "commands": np.vstack([p.u_motor for p in plans]),
        "predicted": np.vstack([p.p_pred_W for p in plans]),
        "reachable": cat("reachable").astype(bool),
        "uncertain": cat("uncertain").astype(bool),
        "spread_m": cat("spread_m").astype(float),
        "iterations": cat("iterations"),
        "time_s": cat("time_s").astype(float),
        "solver": solver,
        "info": info,
    }


def run_offline(spec, out, *, command: str | None = None, say: Callable | None = None, max_points: int):
    """``track --rig none`` for ``spec`` (a :class:`lab.jobs.track.TrackSpec` with a model):
    solve the IK for every target on a smooth path (``spec.ik`` with ``smooth_path``) and
    write the result JSON ``out`` and ``OUT.commands.csv`` together (atomic). ``max_points``:
    the most targets. Returns the :class:`SolvedTargets`. InputError, before any work, for
    an ``OUT.commands.csv`` this program did not write (nothing changed); and for a direct
    inverse model, a model with another
    number of outputs than the targets' 3 columns, a built-in trajectory for a model not
    trained on a shipped robot's data (those are in the shipped arms' frames), a model
    without recorded data bounds nor a shipped robot, too many targets.

    Parameters
    ----------
    spec : TrackSpec
        The ``track`` settings, with a model and ``rig`` none.
    out : str or Path
        The result JSON file; the commands go to ``OUT.commands.csv``.
    command : str, optional
        The command line, recorded in ``info``.
    say : callable, optional
        Called with each note (str) for the terminal.
    max_points : int
        The most targets.

    Returns
    -------
    SolvedTargets
        The IK's answers, as written.
    """
    say = say or (lambda line: None)
    t0 = time.perf_counter()
    check_commands_file(commands_path(out))
    model = load_model(spec.model)
    check_forward(model)
    try:
        forward_markers(model)
    except InputError as err:
        raise spec.field_error(f"{spec.name_of('model')} {spec.model}: {err}", "model") from None
    robot_name = trained_robot(model)
    if spec.trajectory in BUILTIN + SIX_CABLE and robot_name is None:
        raise spec.field_error(
            f"{spec.name_of('trajectory')} {spec.trajectory}: the built-in trajectories are in the shipped arms' "
            "frames (circle, square, rose, helix: the three-cable arm's; six-*: the six-cable arm's), and "
            f"{spec.name_of('model')} {spec.model} was not trained on a shipped robot's data: give a CSV with "
            "header x,y,z (metres) in your robot's frame",
            "trajectory",
            "model",
        )
    targets = load_trajectory(spec.trajectory, spec.n_points)
    if len(targets) > max_points:
        message = f"{spec.name_of('trajectory')} {spec.trajectory}: {len(targets)} points, at most {max_points}"
        raise spec.field_error(message, "trajectory")
    bounds = data_bounds(model)
    robot = load_robot(robot_name) if robot_name is not None else None
    if bounds is None and robot is None:
        raise spec.field_error(
            f"{spec.name_of('model')} {spec.model} records no bounds of its training data (a file saved before "
            "they were recorded) and was not trained on a shipped robot's data: there is no box of commands to "
            "solve in; train it again with `python -m lab train`",
            "model",
        )
    sol = solve_targets(model, targets, spec.ik.replace(smooth_path=True), robot=robot, bounds=bounds)
    solver = sol["solver"]
    for note in solver.notes:
        say(f"IK: {note}")
    t_ik = float(np.sum(sol["time_s"]))
    name = spec.trajectory if spec.trajectory in BUILTIN + SIX_CABLE else Path(spec.trajectory).name
    result = SolvedTargets(
        name, targets, sol["commands"], sol["predicted"], sol["reachable"], sol["uncertain"], sol["spread_m"],
        sol["iterations"], history_of(model), solver.commands.lo, solver.commands.hi, has_spread(model),
        {"ik_total_s": t_ik, "ik_per_target_mean_s": float(np.mean(sol["time_s"])),
         "ik_per_target_max_s": float(np.max(sol["time_s"])), "total_s": time.perf_counter() - t0},
        {**_info(spec, solver, sol["info"], robot, command), "uncertainty_source": spread_source(model)},
    )  # fmt: skip
    doc = json.dumps(_plain(result.to_json()), indent=1, allow_nan=False) + "\n"
    atomic_write_group({commands_path(out): result.commands_csv(), out: doc})
    return result


def _info(spec, solver, follow: dict, robot, command) -> dict:
    """The ``info`` of the result file: model, robot, the IK's settings and what it did."""
    cfg = solver.config
    return {
        "model": spec.model,
        "robot": None if robot is None else robot.name,
        "command_unit": "rad" if robot is not None else "as in the training data",
        "safety_limits": 0 if robot is None else len(robot.safety_limits),
        "solver": {
            "method": cfg.method,
            "tol_m": cfg.tol_m,
            "reach_tol_m": cfg.reach_tol_m,
            "spread_weight": cfg.spread_weight,
            "max_spread_m": cfg.max_spread_m,
            "smooth_path": cfg.smooth_path,
            "notes": list(solver.notes),
            **{k: follow[k] for k in ("reg_weight", "posture_weight", "regularisation", "redundant")},
            "ik": {k: follow[k] for k in ("slack_plateaus", "restarts", "recovered")},
        },
        "command": command,
        "code_version": code_version(),
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }
