"""The repeat check of a capture: the first command measured again after the last.

A robot that creeps over minutes, drifts or is knocked during a capture gives another tip
for the same command later on. With ``repeat_check`` (:func:`lab.capture.session.capture`)
the first command is measured once more once every command is captured; :func:`repeat_note`
is the journal's ``repeat-check`` note on it (flagged as drift beyond
:func:`repeat_threshold_m`) and :func:`repeat_check_line` the line a capture reports.
Details: ``docs/design/rig.md``, "The repeat check".
"""

from __future__ import annotations

import numpy as np

from lab.capture.protocol import Protocol, Sample

#: A repeat of the first command is flagged when its tip lies further than this many of the
#: protocol's tolerances (settle_tol_m or predict_tol_m) from the first measurement: each
#: sample is within about one tolerance of where the tip was going, so two of an unchanged
#: robot differ by up to two plus the reading noise (docs/design/rig.md, "The repeat check").
REPEAT_TOLERANCES = 4.0


def repeat_threshold_m(protocol: Protocol) -> float:
    """Distance above which a repeated command's tip says the robot changed.

    Parameters
    ----------
    protocol : Protocol
        The capture settings (``settle_tol_m``, or ``predict_tol_m`` when predictive).

    Returns
    -------
    float
        :data:`REPEAT_TOLERANCES` times the protocol's tolerance, in m.
    """
    tol = protocol.predict_tol_m if protocol.kind == "predictive" else protocol.settle_tol_m
    return REPEAT_TOLERANCES * tol


def repeat_note(first: dict, again: Sample, protocol: Protocol) -> dict:
    """The journal's ``repeat-check`` note on the first command measured again.

    Parameters
    ----------
    first : dict
        The first sample's journal row (``x``, ``y``, ``z`` in m, ``t_done_s`` in s).
    again : Sample
        The same command measured after the last.
    protocol : Protocol
        The capture settings (the threshold).

    Returns
    -------
    dict
        ``u_motor`` (rad), ``p_first_m`` and ``p_again_m`` (m, frame W), ``t_first_s`` and
        ``t_again_s`` (s, rig clock), ``distance_m``, ``threshold_m`` (m) and ``drift``.
    """
    p_first = np.array([first["x"], first["y"], first["z"]], float)
    distance = float(np.linalg.norm(again.p_tip_W - p_first))
    threshold = repeat_threshold_m(protocol)
    return {
        "u_motor": [float(v) for v in again.u_motor],
        "p_first_m": p_first.tolist(),
        "p_again_m": [float(v) for v in again.p_tip_W],
        "t_first_s": float(first["t_done_s"]),
        "t_again_s": float(again.t_done_s),
        "distance_m": distance,
        "threshold_m": threshold,
        "drift": bool(distance > threshold),
    }


def repeat_check_line(capture) -> str:
    """One line on a capture's repeat check ("" if it has none): how far the first command's
    tip moved between the first sample and its repeat after the last, and whether that says
    the samples drift (creep over minutes, a drifting rig or mocap frame).

    Parameters
    ----------
    capture : lab.capture.Capture
        A finished capture (its journal's ``repeat-check`` note).

    Returns
    -------
    str
        The line, or "" without a repeat check.
    """
    rc = capture.repeat_check
    if rc is None:
        return ""
    mm = 1e3 * rc["distance_m"]
    minutes = (rc["t_again_s"] - rc["t_first_s"]) / 60.0  # negative: the rig's clock restarted
    when = f"{minutes:.0f} min later" if minutes >= 0 else "in a later session"
    if rc["drift"]:
        return (
            f"samples drift: the first command, measured again {when}, gave a tip "
            f"{mm:.2f} mm away (more than {1e3 * rc['threshold_m']:.2f} mm); the robot changed during the capture "
            "(creep over minutes, a moved base or mocap frame), so its samples depend on their history"
        )
    return f"repeat check: the first command measured again {when}, {mm:.2f} mm away"
