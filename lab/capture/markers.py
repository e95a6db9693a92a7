"""What a capture reads of a robot's markers, and its reset command for any tendon control.

A robot with ``[[markers]]`` is observed at every marker, the tip first
(``robot.marker_names``); a reading of the capture protocol is each marker's mean over the
valid frames of its period (:func:`mean_markers`), the frames' markers as a rig gives them
(:func:`frame_markers`: ``MocapFrame.markers_W``). The settle test and the
predictive protocol watch the tip alone. :func:`reset_command` is the reset's contraction for
angle cables and tension-controlled tendons alike.
"""

from __future__ import annotations

import numpy as np

from lab.rig.base import RigError

__all__ = ["frame_markers", "mean_markers", "reset_command"]


def reset_command(robot, protocol) -> np.ndarray:
    """The reset's contraction: every spool angle to ``reset_u_rad``, every tension-controlled
    tendon to half its ``tension_max_n`` (pulled, then released to zero like the cables).

    Parameters
    ----------
    robot : RobotDescription
        The robot (its inputs' controls and bounds).
    protocol : Protocol
        The capture settings.

    Returns
    -------
    numpy.ndarray
        The reset command, shape (m,): rad for angles, N for tensions.
    """
    m = robot.n_inputs
    if robot.all_angle:
        return np.full(m, protocol.reset_u_rad)
    cables = [0.5 * c.tension_max_n if c.control == "tension" else protocol.reset_u_rad for c in robot.cables]
    return np.array(cables + [max(c.bounds[0], 0.0) for c in robot.chambers], float)  # chambers vented


def frame_markers(frame, n_markers: int, rig_kind: str = "this") -> np.ndarray:
    """A frame's markers (K, 3) m: its ``markers_W``; a rig that sees the tip alone cannot
    capture a robot with markers (:class:`~lab.rig.base.RigError`).

    Parameters
    ----------
    frame : MocapFrame
        The frame.
    n_markers : int
        The robot's K observed points (the tip first).
    rig_kind : str
        The rig's kind, for the message.

    Returns
    -------
    numpy.ndarray
        Shape (K, 3), m, frame W.
    """
    if frame.markers_W is None:
        raise RigError(
            f"the {rig_kind} rig reports the tip alone, but the robot has {n_markers - 1} more markers: "
            "capture it on a rig that sees every marker, or describe the robot without [[markers]]"
        )
    return np.asarray(frame.markers_W, dtype=float).reshape(n_markers, 3)


def mean_markers(markers: list, n_markers: int) -> np.ndarray:
    """Each marker's mean over the frames it was seen in, NaN where never seen.

    Parameters
    ----------
    markers : list of numpy.ndarray
        Frames' markers, each shape (K, 3), m.
    n_markers : int
        K.

    Returns
    -------
    numpy.ndarray
        Shape (K, 3), m.
    """
    if not markers:
        return np.full((n_markers, 3), np.nan)
    stack = np.asarray(markers, dtype=float)
    seen = np.isfinite(stack)
    n = seen.sum(axis=0)
    total = np.where(seen, stack, 0.0).sum(axis=0)
    return np.where(n > 0, total / np.maximum(n, 1), np.nan)
