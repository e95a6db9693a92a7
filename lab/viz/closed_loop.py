"""Figure of the closed-loop chapter (09): tracking error per pass, open loop to corrected.

:func:`plot_passes` draws the passes of one run in the plane of its shape (y-z, cm): the
target pink, each pass's achieved tips in a colour of its own.
:func:`plot_closed_loop` draws the mean error (cm, log axis) against the pass, one panel
per correction mode, one line per (model, trajectory): colour by model, marker by
trajectory; the chapter's goals (0.03 cm with the real-data model, 0.05 cm with the
sim-data model) as dotted lines in the models' colours. Rows from
:func:`lab.studies.closed_loop_table.pass_rows`.
"""

from __future__ import annotations

import numpy as np

from lab.viz.style import MODEL_COLOR, SERIES_COLORS, SIM_ONLY_COLOR, achieved_kw, plain_log_ticks, target_kw

__all__ = ["MODEL_COLORS", "TRAJECTORY_MARKERS", "plot_closed_loop", "plot_passes"]

#: The real-data model blue (a model's colour), the sim-data model red (as sim-only in chapter 05).
MODEL_COLORS = {"real": MODEL_COLOR, "sim": SIM_ONLY_COLOR}
TRAJECTORY_MARKERS = {"circle": "o", "square": "s", "rose": "^", "helix": "D"}
MODE_TITLES = {"ilc": "iterative learning control (whole passes)", "feedback": "per-target feedback (iterations)"}


def plot_closed_loop(rows, *, metric: str = "mean_error_m", figsize=(11, 4.2)):
    """Error ``metric`` (m, drawn in cm, log axis) against the pass, one panel per mode (ILC
    first), with the chapter's goals; ValueError when there are no rows.

    Parameters
    ----------
    rows : list of dict
        Rows of :func:`lab.studies.closed_loop_table.pass_rows`: ``trajectory``, ``model``,
        ``mode``, ``pass`` and the metric.
    metric : str, optional
        The error column (m): ``mean_error_m`` or ``max_error_m``.
    figsize : tuple of float, optional
        Figure size (inches).

    Returns
    -------
    tuple
        ``(fig, axes)``: the matplotlib Figure and its axes as a flat array, one per mode.
    """
    import matplotlib.pyplot as plt

    from lab.studies.closed_loop_table import GOALS_M

    present = list(dict.fromkeys(r["mode"] for r in rows))
    modes = [m for m in MODE_TITLES if m in present] + [m for m in present if m not in MODE_TITLES]
    if not modes:
        raise ValueError("no closed-loop rows to plot")
    fig, axes = plt.subplots(1, len(modes), figsize=figsize, layout="constrained", squeeze=False, sharey=True)
    for ax, mode in zip(axes[0], modes):
        mine = [r for r in rows if r["mode"] == mode]
        for key in dict.fromkeys((r["model"], r["trajectory"]) for r in mine):
            line = sorted((r for r in mine if (r["model"], r["trajectory"]) == key), key=lambda r: r["pass"])
            model, traj = key
            ax.plot(
                [r["pass"] for r in line],
                [100 * r[metric] for r in line],
                marker=TRAJECTORY_MARKERS.get(traj, "x"),
                color=MODEL_COLORS.get(model, "k"),
                lw=1.6,
                ms=5,
                label=f"{model}-data model, {traj}",
            )
        for model in dict.fromkeys(r["model"] for r in mine):
            if model in GOALS_M:
                goal_cm = 100 * GOALS_M[model]
                ax.axhline(goal_cm, color=MODEL_COLORS.get(model, "k"), ls=":", lw=1.0)
                ax.text(
                    1.01, goal_cm, f"goal {goal_cm:.2f}", color=MODEL_COLORS.get(model, "k"), fontsize=7,
                    va="center", transform=ax.get_yaxis_transform(),
                )  # fmt: skip
        passes = sorted({r["pass"] for r in mine})
        ax.set_xticks(passes, ["0\n(open loop)" if p == 0 else str(p) for p in passes])
        ax.set_yscale("log")
        plain_log_ticks(ax, "y")
        ax.set_xlabel("pass [1]" if mode == "ilc" else "iteration at each target [1]")
        ax.set_title(MODE_TITLES.get(mode, mode), fontsize=10)
        ax.grid(alpha=0.3, which="major")
    what = "mean" if metric == "mean_error_m" else "max" if metric == "max_error_m" else metric
    axes[0, 0].set_ylabel(f"{what} distance from target [cm]")
    axes[0, 0].legend(fontsize=7, loc="upper right")
    return fig, np.ravel(axes)


def plot_passes(doc: dict, ax=None, *, title: str = ""):
    """The target (pink) and each pass's achieved tips of one closed-loop run, y-z in cm,
    equal scales, the legend with each pass's mean error.

    Parameters
    ----------
    doc : dict
        A run as written by the closed-loop study: ``targets`` (N, 3) m and ``passes``, each
        with ``pass``, ``achieved`` (N, 3) m and ``mean_error_m``.
    ax : matplotlib.axes.Axes, optional
        Where to draw (None: a new figure).
    title : str, optional
        The axes' title.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(5.2, 4.8), layout="constrained")
    target = 100 * np.asarray(doc["targets"], float)
    ax.plot(target[:, 1], target[:, 2], "-", **target_kw(lw=2.0))
    for i, p in enumerate(doc["passes"]):
        tip = 100 * np.asarray(p["achieved"], float)
        what = " (open loop)" if p["pass"] == 0 else ""
        label = f"pass {p['pass']}{what}: mean {100 * p['mean_error_m']:.3f} cm"
        ax.plot(
            tip[:, 1], tip[:, 2], ".", **achieved_kw(ms=3, label=label, color=SERIES_COLORS[i % len(SERIES_COLORS)])
        )
    ax.set(xlabel="y [cm]", ylabel="z [cm]", aspect="equal")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="center")  # inside the closed shape: pinned, not "best"
    ax.grid(True, alpha=0.3)
    return ax
