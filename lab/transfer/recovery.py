"""Does calibration find the true as-built parameters? Recovered against true on a family.

An emulated as-built robot knows its own defects (:class:`lab.asbuilt.arm.Defects`), so
its true theta is known: softness, stiffness gradient (size times its direction's y, z),
each cable's eyelet shift (y, z) and slack. :func:`recovery_rows` samples the robot's
settled tips (the capture protocol's quasi-static map, with its motion-capture noise) at
N commands, calibrates the nominal description to them, and returns one row per
parameter: true, recovered, the calibration's standard deviations (reported, raw and
inflated), the nominal, and the fit's chi-square test (:func:`lab.transfer.model_check`).
:func:`recovery_summary` measures the coverage: how often the truth lies within two
standard deviations, with the raw and with the inflated ones.

What the FEM's theta does not hold stays out of the comparison and acts as model error:
eyelet shifts along the body (x), play, lag and hysteresis; slack absorbs part of the
play (both are dead zones of the cable).
"""

from __future__ import annotations

import numpy as np

from lab.description import RobotDescription
from lab.fem.solve.parameter_layout import AXES, ParameterLayout

__all__ = [
    "true_theta",
    "recovery_rows",
    "family_recovery",
    "recovery_summary",
    "summary_table",
    "robot_coverage",
    "RECOVERY_COLUMNS",
    "write_recovery",
    "read_recovery",
]

#: Columns of a recovery study's CSV (:func:`write_recovery`): ``family`` ("random", "foam",
#: ...) and the keys of :func:`recovery_rows`.
RECOVERY_COLUMNS = (
    "family", "robot", "parameter", "unit", "true", "recovered", "std", "std_raw", "std_inflated", "nominal",
    "n_real", "rms_nominal_m", "rms_m", "expected_rms_m", "reduced_chi2", "model_discrepancy",
)  # fmt: skip
_TEXT = ("family", "robot", "parameter", "unit")


def true_theta(layout: ParameterLayout, defects, *, play_as_slack: bool = False) -> np.ndarray:
    """The theta (p,) of ``layout`` that an as-built robot's ``defects`` amount to (eyelet
    shifts along the axes of ``layout``; any other component is left out). ``play_as_slack``:
    slack plus play -- what the capture protocol's settled tips see, since a cable approached
    from the reset (contraction ``max(h, r u - h)``) pulls exactly like one with ``h`` more
    slack once ``r u > 2 h``.

    Parameters
    ----------
    layout : ParameterLayout
        The calibration's parameter layout (:mod:`lab.fem.solve.parameters`).
    defects : Defects
        The as-built robot's defects (:class:`lab.asbuilt.arm.Defects`).
    play_as_slack : bool
        Count each cable's play (m) as slack.

    Returns
    -------
    numpy.ndarray
        theta, shape (p,): ln(softness), gradient (y, z), eyelet shifts (m) and slack (m)
        in the order of ``layout``.
    """
    g = defects.gradient * np.asarray(defects.gradient_direction_W)[1:]
    shifts = np.array([c.via_shift_m for c in defects.cables], float)
    shifts[:, [i for i in range(3) if i not in AXES[layout.axes]]] = 0.0  # not in theta
    slack = defects.slack_m + (defects.play_m if play_as_slack else 0.0)
    return layout.pack(defects.softness, g, shifts, slack)


def recovery_rows(
    robot: RobotDescription,
    defects,
    u_real,
    *,
    label: str = "",
    seed: int = 0,
    n_rings: int | None = None,
    n_axial: int | None = None,
    noise_m: float | None = None,
    play_as_slack: bool = False,
    algorithm: str | None = None,
) -> list[dict]:
    """Calibrate ``robot`` to the emulated robot with ``defects`` at commands ``u_real``
    (N, m) rad (settled tips plus its mocap noise, seeded by ``seed``), on one mesh for the
    robot and the fit (default: the description's), with the fit's declared noise
    ``noise_m`` (m per coordinate; default :func:`lab.transfer.calibrate`'s). One row per
    parameter: ``robot`` (``label``), ``parameter``, ``unit``, ``true``, ``recovered``,
    ``std`` (the reported one), ``std_raw``, ``std_inflated``, ``nominal``, plus ``n_real``,
    ``rms_nominal_m``, ``rms_m`` (tip misfit before and after, m), ``expected_rms_m``,
    ``reduced_chi2`` and ``model_discrepancy`` (the fit's chi-square test).
    ``play_as_slack``: the true slack includes the play (:func:`true_theta`).

    Parameters
    ----------
    robot : RobotDescription
        The nominal description that is calibrated.
    defects : Defects
        The emulated robot's defects (:class:`lab.asbuilt.arm.Defects`).
    u_real : array_like
        Commands, shape (N, m), rad.
    label : str
        The ``robot`` column of the rows.
    seed : int
        Seed of the motion-capture noise.
    n_rings, n_axial : int, optional
        The mesh of the robot and the fit (default: the description's).
    noise_m : float, optional
        The fit's declared noise, m per coordinate.
    play_as_slack : bool
        The true slack includes the play.
    algorithm : str, optional
        The fit's Levenberg-Marquardt loop (:func:`lab.transfer.calibrate`; default its default).

    Returns
    -------
    list of dict
        One row per parameter, keys as above (softness as a factor, lengths in m).
    """
    from lab.rig.twin import AsBuiltBody, quasi_static_tips
    from lab.transfer.calibrate import calibrate

    u = np.asarray(u_real, float)
    body = AsBuiltBody(robot, defects, n_rings=n_rings, n_axial=n_axial)
    tips = quasi_static_tips(body, u, defects.noise_sigma_m, seed)
    kw = {} if noise_m is None else {"noise_m": noise_m}
    res = calibrate(robot, u, tips, n_rings=n_rings, n_axial=n_axial, algorithm=algorithm, **kw)
    check = res.check
    truth = true_theta(res.layout, defects, play_as_slack=play_as_slack)
    # theta's first entry is ln(softness): report the softness itself
    values, std, std_raw = res.theta.copy(), res.std.copy(), res.std_raw.copy()
    nominal = res.theta_nominal.copy()
    names, units = list(res.layout.names), list(res.layout.units)
    if "softness" in res.layout.groups:
        values[0], truth[0], nominal[0] = np.exp(values[0]), np.exp(truth[0]), 1.0
        std[0], std_raw[0] = values[0] * std[0], values[0] * std_raw[0]
        names[0], units[0] = "softness", "1"
    return [
        {
            "robot": label,
            "parameter": n,
            "unit": unit,
            "true": float(t),
            "recovered": float(v),
            "std": float(s),
            "std_raw": float(sr),
            "std_inflated": float(s),
            "nominal": float(v0),
            "n_real": len(u),
            "rms_nominal_m": res.rms_nominal_m,
            "rms_m": res.rms_m,
            "expected_rms_m": check["expected_rms_m"],
            "reduced_chi2": check["reduced_chi2"],
            "model_discrepancy": check["model_discrepancy"],
        }
        for n, unit, t, v, s, sr, v0 in zip(names, units, truth, values, std, std_raw, nominal)
    ]


def _member_rows(robot, label, u, seed, n_rings, n_axial, noise_m, algorithm, first=None) -> list[dict]:
    from lab.asbuilt.family import family_member
    from lab.transfer.samples import remember_first_pass
    from lab.workers import watch_parent

    watch_parent()
    remember_first_pass(first)
    defects = family_member(robot, label, n_rings=n_rings, n_axial=n_axial)
    return recovery_rows(
        robot,
        defects,
        u,
        label=label,
        seed=seed,
        n_rings=n_rings,
        n_axial=n_axial,
        noise_m=noise_m,
        algorithm=algorithm,
    )


def family_recovery(
    robot: RobotDescription,
    labels,
    u_real,
    *,
    seed: int = 0,
    n_rings: int | None = None,
    n_axial: int | None = None,
    n_jobs: int = 1,
    noise_m: float | None = None,
    algorithm: str | None = None,
) -> list[dict]:
    """:func:`recovery_rows` for each robot of ``labels`` (``"shipped"``, ``"random:SEED"``;
    :func:`lab.asbuilt.family.family_member`), in ``n_jobs`` worker processes (one BLAS thread
    each), rows in the order of ``labels``; ``noise_m`` and ``algorithm`` as there. The workers
    start from the calibration's first pass this process remembers
    (:func:`lab.transfer.samples.remembered_first_pass`), where it is theirs.

    Parameters
    ----------
    robot : RobotDescription
        The nominal description that is calibrated.
    labels : sequence of str
        The family's robots, e.g. ``"shipped"``, ``"random:3"``.
    u_real : array_like
        Commands, shape (N, m), rad.
    seed : int
        Seed of the motion-capture noise.
    n_rings, n_axial : int, optional
        The mesh of the robots and the fits (default: the description's).
    n_jobs : int
        Worker processes.
    noise_m : float, optional
        The fits' declared noise, m per coordinate.
    algorithm : str, optional
        The fits' Levenberg-Marquardt loop (:func:`lab.transfer.calibrate`).

    Returns
    -------
    list of dict
        The rows of :func:`recovery_rows` of every robot, in the order of ``labels``.
    """
    from joblib import Parallel, delayed

    from lab.transfer.samples import remembered_first_pass
    from lab.workers import worker_config

    u = np.asarray(u_real, float)
    first = remembered_first_pass() if n_jobs > 1 else None  # (the workers' calibrations start from it)
    with worker_config():
        parts = Parallel(n_jobs=max(1, min(n_jobs, len(labels))))(
            delayed(_member_rows)(robot, label, u, seed, n_rings, n_axial, noise_m, algorithm, first)
            for label in labels
        )
    return [r for part in parts for r in part]


def _block(name: str) -> str:
    if name == "softness" or name.startswith("gradient"):
        return name.split("[")[0]
    return "eyelet shift" if "shift" in name else "slack"


def recovery_summary(rows: list[dict]) -> list[dict]:
    """Per parameter block (softness, gradient components, eyelet shift, slack) over all
    robots: ``rms_error`` and ``rms_spread`` (RMS of recovered - true and of true - nominal,
    in the block's unit: what calibration leaves against what the nominal robot gets
    wrong) and ``within_2std`` (the fraction of recovered values within two of their
    standard deviations of the truth: the coverage of the 2-sigma intervals), with rows
    that have them also ``within_2std_raw`` and ``within_2std_inflated``.

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`recovery_rows` (one or several robots).

    Returns
    -------
    list of dict
        One row per block: ``block``, ``unit``, ``n``, ``rms_error``, ``rms_spread`` and
        the ``within_2std*`` fractions (0 to 1).
    """
    out = {}
    for r in rows:
        out.setdefault(_block(r["parameter"]), []).append(r)
    summary = []
    for block, rs in out.items():
        err = np.array([r["recovered"] - r["true"] for r in rs])
        spread = np.array([r["true"] - r["nominal"] for r in rs])
        row = {
            "block": block,
            "unit": rs[0]["unit"],
            "n": len(rs),
            "rms_error": float(np.sqrt(np.mean(err**2))),
            "rms_spread": float(np.sqrt(np.mean(spread**2))),
        }
        for key in ("std", "std_raw", "std_inflated"):
            if all(key in r for r in rs):
                std = np.array([r[key] for r in rs])
                row["within_2" + key] = float(np.mean(np.abs(err) <= 2 * std))
        summary.append(row)
    return summary


def robot_coverage(rows: list[dict], std: str = "std_inflated") -> dict:
    """Per robot of ``rows`` (:func:`recovery_rows`, several robots): ``label -> (coverage,
    flagged)``, the fraction of its parameters within two ``std`` of the truth and whether
    the fit's chi-square test flagged a model discrepancy. A robot under 90 % coverage that
    is not flagged is one whose intervals miss silently."""
    by_robot: dict = {}
    for r in rows:
        by_robot.setdefault(r["robot"], []).append(r)
    return {
        label: (
            float(np.mean([abs(r["recovered"] - r["true"]) <= 2 * r[std] for r in rs])),
            bool(rs[0]["model_discrepancy"]),
        )
        for label, rs in by_robot.items()
    }


def summary_table(rows: list[dict], indent: str = "    ") -> str:
    """:func:`recovery_summary` of ``rows`` as a text table, one line per block: coverage
    with the raw and the inflated std, RMS error and RMS spread (m shown in mm)."""
    lines = [f"{indent}{'block':<14}{'n':>4}{'raw':>8}{'inflated':>10}{'RMS error':>12}{'RMS spread':>12}"]
    for s in recovery_summary(rows):
        scale, unit = (1e3, "mm") if s["unit"] == "m" else (1.0, "")
        lines.append(
            f"{indent}{s['block']:<14}{s['n']:>4}{s['within_2std_raw']:>8.0%}{s['within_2std_inflated']:>10.0%}"
            f"{scale * s['rms_error']:>9.3f} {unit:<2}{scale * s['rms_spread']:>9.3f} {unit}"
        )
    return "\n".join(lines)


def write_recovery(path, rows: list[dict], meta: dict) -> None:
    """Rows of :data:`RECOVERY_COLUMNS` as CSV (atomic) with the JSON sidecar ``PATH.json`` (``meta``)."""
    import csv
    import io
    import json

    from lab.files import atomic_write_text

    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(RECOVERY_COLUMNS), lineterminator="\n", extrasaction="ignore")
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(path, buf.getvalue())
    atomic_write_text(f"{path}.json", json.dumps({"format_version": 1, **meta}, indent=2) + "\n")


def read_recovery(path) -> list[dict]:
    """The rows of a recovery study's CSV (:func:`write_recovery`): numbers as float,
    ``n_real`` as int, ``model_discrepancy`` as bool. InputError names a bad file or cell."""
    from lab.errors import InputError
    from lab.files import read_csv_table

    rows = read_csv_table(path, RECOVERY_COLUMNS, "calibration recovery table")
    for line, r in enumerate(rows, start=2):
        try:
            for k in RECOVERY_COLUMNS:
                if k == "n_real":
                    r[k] = int(r[k])
                elif k == "model_discrepancy":
                    if r[k] not in ("True", "False"):
                        raise ValueError(r[k])
                    r[k] = r[k] == "True"
                elif k not in _TEXT:
                    r[k] = float(r[k])
        except ValueError:
            raise InputError(f"{path}, line {line}, column {k!r}: not a valid value ({r[k]!r})") from None
    return rows
