"""Closed-loop result files as a per-pass table (chapter 09; files in ``data/closed_loop/``).

:func:`pass_rows` reads ``track --closed-loop`` results (:mod:`lab.tracking.closed_loop`) into one row per
(trajectory, model, mode, pass); :func:`.pass_rows` output feeds
:func:`lab.viz.closed_loop.plot_closed_loop`. :func:`final_pass_by_limit` splits a run's last
pass into targets whose commands sit on the allowed set's boundary (:func:`at_limit`) and
the rest: where the safety rule, not the correction, sets the error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lab.tracking.track import TrackResultError, read_result

#: the chapter's goals, mean error in m after the passes: per model label
GOALS_M = {"real": 3e-4, "sim": 5e-4}


def model_label(model_path) -> str:
    """The label of a model file in the closed-loop table.

    Parameters
    ----------
    model_path : str or Path
        The model file.

    Returns
    -------
    str
        ``"real"``/``"sim"`` for the shipped ``model_{real,sim}_*.npz``, else the file's stem.
    """
    stem = Path(str(model_path)).stem
    for label in ("real", "sim"):
        if stem.startswith(f"model_{label}_"):
            return label
    return stem


def pass_rows(paths) -> list[dict]:
    """One row per (trajectory, model, mode, pass) from closed-loop result files.

    A file that is no closed-loop result raises :class:`.track.TrackResultError`.

    Parameters
    ----------
    paths : str, Path or list of str or Path
        A folder (its ``*.json``), one file or a list of files written by ``track --closed-loop``.

    Returns
    -------
    list of dict
        Rows ``trajectory, model, mode, pass, mean_error_m, max_error_m, n_skipped, file``
        (errors in m), in file order then pass order.
    """
    if isinstance(paths, (str, Path)) and Path(paths).is_dir():
        paths = sorted(Path(paths).glob("*.json"))
    elif isinstance(paths, (str, Path)):
        paths = [paths]
    rows = []
    for path in paths:
        doc = read_result(path)
        if not isinstance(doc.get("passes"), list) or "closed_loop" not in doc.get("info", {}):
            raise TrackResultError(f"{path}: not a closed-loop track result (no 'passes')")
        for p in doc["passes"]:
            rows.append(
                {
                    "trajectory": doc.get("trajectory", "custom"),
                    "model": model_label(doc["info"].get("model") or "soft-ik"),
                    "mode": doc["info"]["closed_loop"]["mode"],
                    "pass": int(p["pass"]),
                    "mean_error_m": float(p["mean_error_m"]),
                    "max_error_m": float(p["max_error_m"]),
                    "n_skipped": int(p.get("n_skipped", 0)),
                    "file": Path(path).name,
                }
            )
    return rows


def at_limit(robot, u_motor, tol_rad: float = 1e-3) -> np.ndarray:
    """Whether each command (N, m) rad lies on the allowed set's boundary, within
    ``tol_rad``: a motor at ``u_max_rad`` or a safety limit's sum at its cap. A target whose
    command sits there may need more than the safety rule allows; no correction gets past it."""
    u = np.atleast_2d(np.asarray(u_motor, dtype=float))
    hit = np.any(u >= robot.u_max_rad - tol_rad, axis=1)
    for lim in robot.safety_limits:
        hit |= u[:, list(lim.cables)].sum(axis=1) >= lim.max_sum_over_u_max * robot.u_max_rad - tol_rad
    return hit


def final_pass_by_limit(path, robot, tol_rad: float = 1e-3) -> dict:
    """The last pass of a closed-loop result split by :func:`at_limit`.

    Parameters
    ----------
    path : str or Path
        A closed-loop track result file.
    robot : RobotDescription
        The robot whose limits (``u_max_rad``, safety limits) define the boundary.
    tol_rad : float, optional
        How close to a limit (rad) counts as on it.

    Returns
    -------
    dict
        ``n``, ``n_at_limit`` (int), ``mean_error_m`` (all targets), ``mean_at_limit_m`` and
        ``mean_inside_m`` (m; NaN when empty).
    """
    doc = read_result(path)
    if not isinstance(doc.get("passes"), list) or not doc["passes"]:
        raise TrackResultError(f"{path}: not a closed-loop track result (no 'passes')")
    last = doc["passes"][-1]
    err = np.linalg.norm(np.asarray(last["achieved"], float) - np.asarray(doc["targets"], float), axis=1)
    hit = at_limit(robot, last["commands"], tol_rad)
    mean = lambda a: float(a.mean()) if len(a) else float("nan")  # noqa: E731
    return {
        "n": len(err),
        "n_at_limit": int(hit.sum()),
        "mean_error_m": mean(err),
        "mean_at_limit_m": mean(err[hit]),
        "mean_inside_m": mean(err[~hit]),
    }
