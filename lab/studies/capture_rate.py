"""Samples per hour against accuracy, per capture protocol, on emulated as-built robots.

:func:`capture_rate_study` captures the same random allowed commands on each robot with
the waiting protocol (the paper's, at several settle tolerances) and the predictive one
(:mod:`lab.capture.predictive`, at several prediction tolerances), on the twin's virtual
clock, and compares every recorded tip with the robot's **noise-free settled tip** for
that command (:meth:`~lab.rig.twin.AsBuiltBody.quasi_static_tip`): the truth a capture
is after. Rates and errors count every sample (the predictive protocol's learning samples, captured by
waiting, included); the ``..._after_learning`` columns only the samples after them. ``benchmarks/bench_capture.py``
and chapter 09 use it; the cache is ``data/capture_rate.csv``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from lab.capture.protocol import Protocol
from lab.capture.session import capture
from lab.description import RobotDescription

#: columns of the study's rows / CSV
COLUMNS = (
    "robot",
    "protocol",
    "tol_m",
    "n",
    "rate_per_hour",
    "rate_after_learning_per_hour",
    "mean_error_m",
    "mean_error_after_learning_m",
    "p95_error_m",
    "max_error_m",
    "n_flagged",
    "mean_pred_std_m",
    "tau_fast_s",
    "tau_slow_s",
    "slow_fraction",
    "true_tau_fast_s",
    "true_tau_slow_s",
    "true_slow_fraction",
)


def protocol_for(kind: str, tol_m: float, **settings) -> Protocol:
    """The capture protocol ``kind`` at tolerance ``tol_m``.

    Parameters
    ----------
    kind : str
        ``"wait"`` (settle, then record) or ``"predictive"``.
    tol_m : float
        The waiting protocol's settle tolerance, or the predictive one's tolerance on the
        prediction's 3-D std (m).
    **settings
        Further :class:`~lab.capture.protocol.Protocol` fields.

    Returns
    -------
    Protocol
        The protocol to pass to :func:`lab.capture.session.capture`.
    """
    if kind == "wait":
        return Protocol(settle_tol_m=tol_m, **settings)
    return Protocol(kind="predictive", predict_tol_m=tol_m, **settings)


def run_protocol(body, commands: np.ndarray, protocol: Protocol, *, seed: int = 0, journal_dir=None) -> dict:
    """Capture ``commands`` on the as-built ``body`` (a twin rig around it) with ``protocol``.

    Parameters
    ----------
    body : AsBuiltBody
        The emulated as-built robot (:class:`lab.rig.twin.AsBuiltBody`); its optional ``label``
        names the row's robot (``"shipped"`` if absent).
    commands : numpy.ndarray, shape (N, m)
        Motor commands (rad).
    protocol : Protocol
        The capture protocol (:func:`protocol_for`).
    seed : int, optional
        Seed of the twin rig's noise.
    journal_dir : str or Path, optional
        Where the temporary capture journal goes (the system's temporary folder if None).

    Returns
    -------
    dict
        One row of :data:`COLUMNS`: rates (samples per hour), errors against the noise-free
        settled tips (m), the learned and the true relaxation times (s) and slow fraction.
    """
    from lab.rig.twin import TwinRig

    robot = body.robot
    truth = np.array([body.quasi_static_tip(u) for u in commands])
    rig = TwinRig(robot, body=body, seed=seed)
    with tempfile.TemporaryDirectory(dir=journal_dir) as tmp:
        res = capture(rig, commands, Path(tmp) / "journal.csv", protocol)
    err = np.linalg.norm(res.p_tip_W - truth, axis=1)
    after = res.predicted if protocol.kind == "predictive" else np.ones(len(err), bool)
    learned = [info for tag, info in res.notes if tag == "relaxation"]
    tau = learned[-1]["tau_s"] if learned else [np.nan, np.nan]
    w = learned[-1]["weight"] if learned else [np.nan, np.nan]
    d = body.defects
    return {
        "robot": getattr(body, "label", "shipped"),
        "protocol": protocol.kind,
        "tol_m": protocol.predict_tol_m if protocol.kind == "predictive" else protocol.settle_tol_m,
        "n": len(err),
        "rate_per_hour": res.rate_per_hour,
        "rate_after_learning_per_hour": 3600.0 * after.sum() / res.sample_s[after].sum(),
        "mean_error_m": float(err.mean()),
        "mean_error_after_learning_m": float(err[after].mean()),
        "p95_error_m": float(np.percentile(err, 95)),
        "max_error_m": float(err.max()),
        "n_flagged": int(np.sum(~res.settled)),
        "mean_pred_std_m": float(np.mean(res.pred_std_m[after])) if protocol.kind == "predictive" else np.nan,
        "tau_fast_s": tau[0],
        "tau_slow_s": tau[-1],
        "slow_fraction": w[-1],
        "true_tau_fast_s": d.tau_fast_s,
        "true_tau_slow_s": d.tau_slow_s,
        "true_slow_fraction": d.slow_fraction,
    }


def capture_rate_study(
    robot: RobotDescription,
    robots=("shipped",),
    *,
    n_samples: int = 100,
    wait_tols_m=(1e-4,),
    predict_tols_m=(1.5e-4,),
    seed: int = 0,
    mesh: dict | None = None,
    progress=None,
) -> list[dict]:
    """Samples per hour and accuracy of each protocol and tolerance, per robot.

    For each robot label, ``n_samples`` random allowed commands (seeded by ``seed``) are
    captured with each tolerance of each protocol.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    robots : sequence of str, optional
        Robot labels: ``"shipped"`` or ``"random:SEED"`` (:func:`lab.asbuilt.family.family_member`).
    n_samples : int, optional
        Commands captured per run.
    wait_tols_m, predict_tols_m : sequence of float, optional
        Settle tolerances of the waiting protocol and prediction tolerances of the predictive
        one (m).
    seed : int, optional
        Seed of the commands and of the twins' noise.
    mesh : dict, optional
        ``n_rings``/``n_axial`` of the emulator's FEM (coarse meshes for tests).
    progress : callable, optional
        ``progress(row)`` is called after each row.

    Returns
    -------
    list of dict
        Rows of :data:`COLUMNS`, robot by robot, the waiting runs before the predictive ones.
    """
    from lab.asbuilt.family import family_member
    from lab.data.designs import random_commands
    from lab.rig.twin import AsBuiltBody

    mesh = mesh or {}
    commands = random_commands(robot, n_samples, seed=seed)
    rows = []
    for label in robots:
        body = AsBuiltBody(robot, family_member(robot, label, **mesh), **mesh)
        body.label = label
        runs = [("wait", t) for t in wait_tols_m] + [("predictive", t) for t in predict_tols_m]
        for kind, tol in runs:
            row = run_protocol(body, commands, protocol_for(kind, tol), seed=seed)
            rows.append(row)
            if progress is not None:
                progress(row)
    return rows


def write_capture_rate(path, rows, command: str) -> None:
    """Rows of :data:`COLUMNS` as CSV (atomic) with a JSON sidecar ``PATH.json``.

    Parameters
    ----------
    path : str or Path
        The CSV file to write.
    rows : list of dict
        Rows of :data:`COLUMNS` (:func:`capture_rate_study`).
    command : str
        The command line recorded in the sidecar.
    """
    import json

    from lab.files import atomic_write_text, code_version

    text = ["robot,protocol," + ",".join(COLUMNS[2:])]
    text += [",".join([r["robot"], r["protocol"], *(repr(float(r[c])) for c in COLUMNS[2:])]) for r in rows]
    atomic_write_text(path, "\n".join(text) + "\n")
    side = {"format_version": 1, "kind": "lab.capture_rate", "command": command, "code_version": code_version()}
    atomic_write_text(f"{path}.json", json.dumps(side, indent=1) + "\n")


def read_capture_rate(path) -> list[dict]:
    """Rows written by :func:`write_capture_rate`; InputError names a bad file.

    Parameters
    ----------
    path : str or Path
        The CSV file.

    Returns
    -------
    list of dict
        Rows of :data:`COLUMNS`: ``robot`` and ``protocol`` as str, every other column as
        float (units as in the column names).
    """
    from lab.files import read_csv_table

    rows = read_csv_table(path, COLUMNS, "capture-rate table")
    return [{k: (v if k in ("robot", "protocol") else float(v)) for k, v in r.items()} for r in rows]
