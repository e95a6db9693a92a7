"""Figures of trajectories at speed: the error against the period, and a streamed shape drawn.

:func:`plot_period_curve` draws the streamed tracking error (mean over the last period, mm)
against the period (s) on log-log axes, one colour per robot, open loop dashed and
feed-forward solid (rows of :mod:`lab.studies.period_curve`). :func:`plot_streamed_trajectory`
draws a target shape with what the tip did over the last period of two streamed runs (track
results of :mod:`lab.tracking.stream`, e.g. open loop and feed-forward at T = 5 s), in the
plane of the shape (y-z, cm). Both put their legend outside the axes, never on the data
(ten curves fill every corner of the period plot, and a closed shape every corner of its
own): beside the period plot, below the shape.
"""

from __future__ import annotations

import numpy as np

from lab.viz.style import SERIES_COLORS, achieved_kw, plain_log_ticks, target_kw

__all__ = ["MODE_STYLES", "plot_period_curve", "plot_streamed_trajectory"]

#: line style and marker per streaming mode
MODE_STYLES = {"open-loop": ("--", "s"), "feed-forward": ("-", "o")}


def plot_period_curve(rows, ax=None, *, goal_ratio: float | None = 3.0, goal_period_s: float = 5.0):
    """Mean error (mm) against period (s), log-log, one curve per rig and model and mode.

    Parameters
    ----------
    rows : list of dict
        Rows of :mod:`lab.studies.period_curve`: ``rig``, ``period_s``, ``mode``,
        ``mean_error_m`` (and ``model``).
    ax : matplotlib.axes.Axes, optional
        Where to draw (None: a new figure).
    goal_ratio : float or None, optional
        Marks per curve the goal: the open loop's error divided by it at ``goal_period_s``.
    goal_period_s : float, optional
        Period of the goal (s).

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 4.2), layout="constrained")

    def key(r):
        return (r["rig"], r.get("model") or "")

    keys = list(dict.fromkeys(key(r) for r in rows))
    several_models = len({k[1] for k in keys}) > 1
    handles = []  # the legend: one entry per curve's colour, then one per mode's line style
    for i, k in enumerate(keys):
        color, label = f"C{i}", f"{k[0]} [{k[1]}]" if several_models else k[0]
        mine = [r for r in rows if key(r) == k]
        handles.append(Line2D([], [], color=color, lw=3, label=label))
        for mode, (ls, marker) in MODE_STYLES.items():
            pts = sorted(
                (float(r["period_s"]), 1e3 * float(r["mean_error_m"]))
                for r in mine
                if r["mode"] == mode and np.isfinite(float(r["mean_error_m"]))
            )
            if pts:
                t, e = np.array(pts).T
                ax.plot(t, e, ls=ls, marker=marker, color=color, ms=4, lw=1.5, label=f"{label}, {mode}")
        open_at = [
            float(r["mean_error_m"]) for r in mine if r["mode"] == "open-loop" and float(r["period_s"]) == goal_period_s
        ]
        if goal_ratio and open_at:
            ax.plot(goal_period_s, 1e3 * open_at[0] / goal_ratio, marker="_", color=color, ms=16, mew=2)
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_ticks(ax)
    periods = sorted({float(r["period_s"]) for r in rows})
    ax.set_xticks(periods, [f"{p:g}" for p in periods])
    ax.minorticks_off()
    ax.set_xlabel("period of the trajectory [s]")
    ax.set_ylabel("mean tracking error, last period [mm]")
    title = "streamed circle: quasi-static open loop (dashed) vs feed-forward (solid)"
    if goal_ratio:
        title += f"\n(bars: {goal_ratio:g}x below open loop at T = {goal_period_s:g} s)"
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="major", alpha=0.3)
    modes = [m for m in MODE_STYLES if any(r["mode"] == m for r in rows)]
    handles += [Line2D([], [], color="0.3", ls=MODE_STYLES[m][0], marker=MODE_STYLES[m][1], label=m) for m in modes]
    if goal_ratio:
        handles.append(Line2D([], [], color="0.3", ls="none", marker="_", ms=12, mew=2, label="goal"))
    fig = ax.figure
    if type(fig.get_layout_engine()).__name__ == "ConstrainedLayoutEngine":  # under the axes, outside them
        fig.legend(handles=handles, fontsize=7, loc="outside lower center", ncol=2)
    else:
        ax.legend(handles=handles, fontsize=7)
    return ax


def _legend_beside(ax) -> None:
    """The legend right of ``ax``, outside it: a closed shape fills every corner."""
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)


def _doc(result):
    """A track result as a dict (a StreamResult or what read_result returns)."""
    return result.to_json() if hasattr(result, "to_json") else result


def plot_streamed_trajectory(results: dict, ax=None):
    """Draws the first result's targets (pink) and each result's measured tip over the
    last period (one colour each, never the target's), y-z plane in cm.

    Parameters
    ----------
    results : dict
        ``{label: streamed track result}`` (StreamResult or its JSON as read by
        :func:`lab.tracking.track.read_result`).
    ax : matplotlib.axes.Axes, optional
        Where to draw (None: a new figure).

    Returns
    -------
    matplotlib.axes.Axes
        ``ax``.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(4.8, 4.8), layout="constrained")
    docs = {label: _doc(r) for label, r in results.items()}
    first = next(iter(docs.values()))
    order = np.argsort(np.asarray(first.get("t_s", np.arange(len(first["targets"]))), float))
    target = 100 * np.asarray(first["targets"], float)[order]
    ax.plot(target[:, 1], target[:, 2], "-", **target_kw(lw=2.0))
    for i, (label, doc) in enumerate(docs.items()):
        tip = 100 * np.asarray(doc["achieved"], float)
        err = 100 * float(doc["mean_error_m"])
        kw = achieved_kw(ms=2, label=f"{label} (mean {err:.2f} cm)", color=SERIES_COLORS[i % len(SERIES_COLORS)])
        ax.plot(tip[:, 1], tip[:, 2], ".", **kw)
    period = first.get("period_s")
    ax.set_title(f"streamed at T = {period:g} s: last period" if period else "streamed trajectory", fontsize=9)
    ax.set_xlabel("y [cm]")
    ax.set_ylabel("z [cm]")
    ax.set_aspect("equal")
    # below the axes: beside it, the legend would sit between this panel and a neighbour
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), borderaxespad=0.0, ncol=1)
    ax.grid(True, alpha=0.3)
    return ax
