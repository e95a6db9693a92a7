"""The error against the period: a trajectory streamed open loop and pre-compensated, per robot.

:func:`period_curve_rows` streams one trajectory (:func:`lab.tracking.stream.stream_trajectory`)
at each period, open loop and through each robot's fitted relaxation filter, on a fresh rig per
run (the same noise seed, settled from rest), and returns one row per (rig, period, mode).
:func:`write_period_curve` writes them as CSV (atomic) with a JSON sidecar ``OUT.json``
(command, code version, settings); ``benchmarks/bench_period_curve.py`` makes
``data/period_curve.csv``. Columns: ``rig`` (its ``--rig`` spec), ``period_s``, ``mode``
("open-loop" or "feed-forward"), ``mean_error_m`` and ``max_error_m`` over the last period's
frames (m), ``model`` (the quasi-static model the IK solved through), ``n_periods``,
``n_knots_unreachable`` (equilibria the IK could not reach), ``max_motor_speed_rad_s`` (the
fastest a motor had to turn between commands) and ``tau_s``/``weight`` of the filter used
(";"-joined, empty in open loop).
"""

from __future__ import annotations

import csv
import io
import json

import numpy as np

from lab.files import atomic_write_text, code_version, read_csv_table

__all__ = [
    "PERIOD_CURVE_COLUMNS",
    "MODES",
    "period_curve_rows",
    "write_period_curve",
    "read_period_curve",
    "write_traces",
    "read_traces",
]

PERIOD_CURVE_COLUMNS = (
    "rig",
    "period_s",
    "mode",
    "mean_error_m",
    "max_error_m",
    "model",
    "n_periods",
    "n_knots_unreachable",
    "max_motor_speed_rad_s",
    "tau_s",
    "weight",
)
MODES = ("open-loop", "feed-forward")
_FLOATS = ("period_s", "mean_error_m", "max_error_m", "max_motor_speed_rad_s")


def period_curve_rows(make_rig, runs, targets_W, periods_s, *, log=None, **stream_kw):
    """Stream a trajectory at every period of ``periods_s``, open loop and feed-forward, per run.

    Parameters
    ----------
    make_rig : callable
        ``make_rig(spec)`` returns a fresh rig (a context manager).
    runs : iterable of tuple
        ``(spec, model_label, solver, relax)``: a rig spec, the name of the quasi-static model
        the ``solver`` (:class:`~lab.control.ik.IKSolver`) solves through, and the fitted
        :class:`~lab.dynamics.relaxation.Relaxation`.
    targets_W : array_like, shape (K, 3)
        The trajectory's targets (m, world frame).
    periods_s : iterable of float
        Periods of the trajectory (s).
    log : callable, optional
        ``log(text)`` is told each result.
    **stream_kw
        Go to :func:`lab.tracking.stream.stream_trajectory`.

    Returns
    -------
    rows : list of dict
        One per (run, period, mode), with :data:`PERIOD_CURVE_COLUMNS` (errors in m, periods in s).
    results : dict
        ``{(spec, model_label, period_s, mode): StreamResult}``.
    """
    from lab.tracking.stream import stream_trajectory

    rows, results = [], {}
    for spec, model_label, solver, relax in runs:
        for period in periods_s:
            for mode in MODES:
                ff = mode == "feed-forward"
                with make_rig(spec) as rig:
                    res = stream_trajectory(
                        rig, solver, targets_W, float(period), relax=relax if ff else None, **stream_kw
                    )
                results[(spec, model_label, float(period), mode)] = res
                rows.append(
                    {
                        "rig": spec,
                        "model": model_label,
                        "period_s": float(period),
                        "mode": mode,
                        "mean_error_m": res.mean_error_m,
                        "max_error_m": res.max_error_m,
                        "n_periods": res.n_periods,
                        "n_knots_unreachable": int(np.sum(~res.knots.reachable)),
                        "max_motor_speed_rad_s": res.knots.max_motor_speed_rad_s,
                        "tau_s": ";".join(f"{t:.6g}" for t in relax.tau_s) if ff else "",
                        "weight": ";".join(f"{w:.6g}" for w in relax.weight) if ff else "",
                    }
                )
                if log is not None:
                    log(
                        f"{spec} ({model_label}) T = {period:g} s {mode}: mean {1e3 * res.mean_error_m:.3f} mm, max "
                        f"{1e3 * res.max_error_m:.3f} mm, {rows[-1]['n_knots_unreachable']} equilibria out of reach"
                    )
    return rows, results


def write_period_curve(path, rows, sidecar: dict | None = None) -> None:
    """Write ``rows`` as CSV (:data:`PERIOD_CURVE_COLUMNS`) and a sidecar, both atomically.

    Parameters
    ----------
    path : str or Path
        The CSV file; the sidecar is ``path.json``.
    rows : list of dict
        Rows of :func:`period_curve_rows`.
    sidecar : dict, optional
        JSON-able settings written into the sidecar (plus the code version).
    """
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=PERIOD_CURVE_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (repr(float(r[k])) if k in _FLOATS else r.get(k, "")) for k in w.fieldnames})
    atomic_write_text(path, buf.getvalue())
    meta = {"kind": "lab.period_curve", "format_version": 1, **(sidecar or {}), "code_version": code_version()}
    atomic_write_text(f"{path}.json", json.dumps(meta, indent=1) + "\n")


def read_period_curve(path) -> list[dict]:
    """The rows of a period-curve CSV; InputError for a missing file or one without the columns.

    Parameters
    ----------
    path : str or Path
        The CSV written by :func:`write_period_curve`.

    Returns
    -------
    list of dict
        Rows of :data:`PERIOD_CURVE_COLUMNS`: numbers as floats (m, s, rad/s), ``n_*`` as ints,
        ``rig``, ``mode``, ``model``, ``tau_s``, ``weight`` as str.
    """
    rows = read_csv_table(path, PERIOD_CURVE_COLUMNS[:5], "period curve")
    out = []
    for r in rows:
        d = dict(r)
        for k in _FLOATS:
            if d.get(k) not in (None, ""):
                d[k] = float(d[k])
        for k in ("n_periods", "n_knots_unreachable"):
            if d.get(k) not in (None, ""):
                d[k] = int(d[k])
        out.append(d)
    return out


TRACE_COLUMNS = ("label", "period_s", "t_s", "target_x", "target_y", "target_z", "x", "y", "z")


def write_traces(path, results: dict) -> None:
    """What the tip did over the last period of streamed runs, for figures: ``results``
    ``{label: StreamResult or its JSON}`` -> CSV (:data:`TRACE_COLUMNS`; m, s; atomic)."""
    lines = [",".join(TRACE_COLUMNS)]
    for label, res in results.items():
        doc = res.to_json() if hasattr(res, "to_json") else res
        t, tg, tip = (np.asarray(doc[k], float) for k in ("t_s", "targets", "achieved"))
        for i in np.argsort(t, kind="stable"):
            nums = [f"{t[i]:.6f}", *(f"{v:.7f}" for v in tg[i]), *(f"{v:.7f}" for v in tip[i])]
            lines.append(",".join([label, f"{float(doc['period_s']):g}", *nums]))
    atomic_write_text(path, "\n".join(lines) + "\n")


def read_traces(path) -> dict:
    """{label: {"period_s", "t_s" (n,), "targets" (n, 3), "achieved" (n, 3), "mean_error_m"}}
    from :func:`write_traces`' CSV (what :func:`lab.viz.dynamics.plot_streamed_trajectory` draws)."""
    rows = read_csv_table(path, TRACE_COLUMNS, "traces file")
    out = {}
    for label in dict.fromkeys(r["label"] for r in rows):
        mine = [r for r in rows if r["label"] == label]
        tg = np.array([[float(r[f"target_{c}"]) for c in "xyz"] for r in mine])
        tip = np.array([[float(r[c]) for c in "xyz"] for r in mine])
        out[label] = {
            "period_s": float(mine[0]["period_s"]),
            "t_s": np.array([float(r["t_s"]) for r in mine]),
            "targets": tg,
            "achieved": tip,
            "mean_error_m": float(np.mean(np.linalg.norm(tip - tg, axis=1))),
        }
    return out
