"""Figure of the closed-loop chapter (09): tracking error per pass, open loop to corrected.

:func:`plot_closed_loop` draws the mean error (cm, log axis) against the pass, one panel
per correction mode, one line per (model, trajectory): colour by model, marker by
trajectory; the chapter's goals (0.03 cm with the real-data model, 0.05 cm with the
sim-data model) as dotted lines in the models' colours. Rows from
:func:`lab.studies.closed_loop_table.pass_rows`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MODEL_COLORS", "TRAJECTORY_MARKERS", "plot_closed_loop"]

MODEL_COLORS = {"real": "C0", "sim": "C3"}
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
        ax.set_xlabel("pass" if mode == "ilc" else "iteration at each target")
        ax.set_title(MODE_TITLES.get(mode, mode), fontsize=10)
        ax.grid(alpha=0.3, which="both")
    what = "mean" if metric == "mean_error_m" else "max" if metric == "max_error_m" else metric
    axes[0, 0].set_ylabel(f"{what} distance from target [cm]")
    axes[0, 0].legend(fontsize=7, loc="upper right")
    return fig, np.ravel(axes)
