"""The repeat check of a capture: the first command measured again after the last.

A robot that creeps over minutes, drifts or is knocked during a capture gives another tip
for the same command later on. With ``repeat_check`` (:func:`lab.capture.session.capture`)
the first command is measured once more once every command is captured; :func:`repeat_note`
is the journal's ``repeat-check`` note on it (flagged as drift beyond
:func:`repeat_threshold_m`) and :func:`repeat_check_line` the line a capture reports.

A repeat check interrupted and resumed runs first thing in a new session, from where the
rig starts -- where it also started the first sample: an emulated twin restarts from rest
with the same noise and gave the first sample back bit for bit ("0.00 mm away"), so the
check could never see drift. A resumed check therefore measures the *last* command again
first, then the first: the last one's journal row was made at the end of the capture, so
its repeat after the restart shows what changed over the capture even when the rig's own
state restarted, and the first command is measured from another state than at the start.
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


def _tip(row: dict) -> np.ndarray:
    return np.array([row["x"], row["y"], row["z"]], float)


def repeat_note(first: dict, again: Sample, protocol: Protocol, last: tuple | None = None) -> dict:
    """The journal's ``repeat-check`` note on the first command measured again.

    Parameters
    ----------
    first : dict
        The first sample's journal row (``x``, ``y``, ``z`` in m, ``t_done_s`` in s).
    again : Sample
        The same command measured after the last.
    protocol : Protocol
        The capture settings (the threshold).
    last : tuple of (dict, Sample), optional
        A resumed check: the last sample's journal row and its command measured again
        (before ``again``).

    Returns
    -------
    dict
        ``u_motor`` (rad), ``p_first_m`` and ``p_again_m`` (m, frame W), ``t_first_s`` and
        ``t_again_s`` (s, rig clock), ``distance_m``, ``threshold_m`` (m) and ``drift``
        (either command beyond the threshold); a resumed check adds ``last`` (``index``,
        ``p_first_m``, ``p_again_m`` and ``distance_m``, m) and ``resumed``.
    """
    p_first = _tip(first)
    distance = float(np.linalg.norm(again.p_tip_W - p_first))
    threshold = repeat_threshold_m(protocol)
    note = {
        "u_motor": [float(v) for v in again.u_motor],
        "p_first_m": p_first.tolist(),
        "p_again_m": [float(v) for v in again.p_tip_W],
        "t_first_s": float(first["t_done_s"]),
        "t_again_s": float(again.t_done_s),
        "distance_m": distance,
        "threshold_m": threshold,
        "drift": bool(distance > threshold),
    }
    if last is not None:
        row, sample = last
        d_last = float(np.linalg.norm(sample.p_tip_W - _tip(row)))
        note["last"] = {
            "index": int(row["index"]),
            "p_first_m": _tip(row).tolist(),
            "p_again_m": [float(v) for v in sample.p_tip_W],
            "distance_m": d_last,
        }
        note.update(resumed=True, drift=bool(max(distance, d_last) > threshold))
    return note


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
    when = f"{minutes:.0f} min later" if minutes >= 0 and not rc.get("resumed") else "in a later session"
    what, away = "the first command", f"{mm:.2f} mm away"
    if "last" in rc:  # resumed: the last command measured again too
        what = "the first and the last command"
        away = f"{mm:.2f} and {1e3 * rc['last']['distance_m']:.2f} mm away"
    if rc["drift"]:
        return (
            f"samples drift: {what}, measured again {when}, gave tips "
            f"{away} (more than {1e3 * rc['threshold_m']:.2f} mm); the robot changed during the capture "
            "(creep over minutes, a moved base or mocap frame), so its samples depend on their history"
        )
    return f"repeat check: {what} measured again {when}, {away}"
