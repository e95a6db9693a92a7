"""Samples per hour against accuracy, per capture protocol (rows of :mod:`lab.studies.capture_rate`).

Each point of the shipped robot's tolerance sweep is labelled with its tolerance (mm). Two
tolerances can land on nearly the same point (the predictive protocol's 0.25 and 0.4 mm in
the shipped sweep), so labels whose text would collide at the drawn size are merged into
one ("0.25, 0.4") at the group's last point.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PROTOCOL_STYLES", "plot_capture_rate"]

#: colour and marker per capture protocol
PROTOCOL_STYLES = {"wait": ("C0", "s"), "predictive": ("C3", "o")}
LABEL_PT = 7  # font size of the tolerance labels


def plot_capture_rate(rows, ax=None, *, after_learning: bool = True, goal_rate_per_hour: float | None = 900.0):
    """Samples per hour of robot time (y) against mean distance from the noise-free settled
    tips (x, mm). The shipped robot's rows are joined into one line per protocol (its
    tolerance sweep, each point labelled with the tolerance in mm); the family's are single
    markers.

    Parameters
    ----------
    rows : iterable of dict
        Rows of :mod:`lab.studies.capture_rate`: ``robot``, ``protocol``, ``tol_m``, the rate
        (per hour) and error (m) columns (CSV strings or numbers).
    ax : matplotlib.axes.Axes, optional
        Where to draw (None: a new figure).
    after_learning : bool, optional
        The predictive protocol's rate and error after its learning samples (else over every
        sample).
    goal_rate_per_hour : float or None, optional
        A goal rate drawn as a dotted line (None: none).

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.2, 4.2), layout="constrained")
    rate_key = "rate_after_learning_per_hour" if after_learning else "rate_per_hour"
    err_key = "mean_error_after_learning_m" if after_learning else "mean_error_m"
    rows = [{**r, "tol_m": float(r["tol_m"]), rate_key: float(r[rate_key]), err_key: float(r[err_key])} for r in rows]
    labels = []  # (x, y, texts) per shipped sweep, drawn once the limits are known
    for protocol, (color, marker) in PROTOCOL_STYLES.items():
        shipped = sorted(
            {r["tol_m"]: r for r in rows if r["protocol"] == protocol and r["robot"] == "shipped"}.values(),
            key=lambda r: r["tol_m"],
        )
        if shipped:
            x = 1e3 * np.array([r[err_key] for r in shipped])
            y = np.array([r[rate_key] for r in shipped])
            ax.plot(x, y, "-", color=color, marker=marker, label=f"{protocol}, shipped robot (tolerance sweep)")
            labels.append((x, y, [f"{1e3 * r['tol_m']:g}" for r in shipped]))
        family = [r for r in rows if r["protocol"] == protocol and r["robot"] != "shipped"]
        if family:
            ax.plot(
                [1e3 * r[err_key] for r in family],
                [r[rate_key] for r in family],
                marker,
                mfc="none",
                color=color,
                ls="none",
                label=f"{protocol}, family members (default tolerance)",
            )
    if goal_rate_per_hour:
        ax.axhline(goal_rate_per_hour, color="0.5", lw=0.8, ls=":", label=f"goal {goal_rate_per_hour:g} per hour")
    ax.set_xlabel("mean distance from the settled tip [mm]")
    ax.set_ylabel("samples per hour of robot time" + (" (after learning)" if after_learning else "") + " [1/h]")
    ax.set_title("capture protocols on emulated as-built robots (labels: tolerance, mm)", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    for x, y, texts in labels:
        for i, text in _merged_labels(ax, x, y, texts, LABEL_PT):
            ax.annotate(text, (x[i], y[i]), textcoords="offset points", xytext=(4, 4), fontsize=LABEL_PT)
    return ax


def _merged_labels(ax, x, y, texts, size_pt: float):
    """``[(index, text)]``: consecutive points whose labels (``size_pt`` text, drawn up and
    right of the point) would overlap at the axes' current scale are merged into one label,
    placed at the group's last point."""
    ax.autoscale_view()
    xy_pt = ax.transData.transform(np.column_stack([x, y])) * 72.0 / ax.figure.dpi
    out: list = []
    for i, text in enumerate(texts):
        if out:
            j, prev = out[-1]
            wide = 0.62 * size_pt * max(len(prev.split(", ")[-1]), len(text)) + 2.0
            dx, dy = np.abs(xy_pt[i] - xy_pt[j])
            if dx < wide and dy < 1.3 * size_pt:
                out[-1] = (i, f"{prev}, {text}")
                continue
        out.append((i, text))
    return out
