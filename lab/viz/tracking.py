"""Figures of trajectory following: a row of Figure 3 and the helix of Figure 4.

Positions are drawn in centimetres in frame W. As in the paper, the planar shapes are
shown projected onto their plane, the y-z plane facing the arm (errors are still 3-D).
Motor commands are colour-coded per cable as in the paper's Figure 2: every cable has
its own colour (:data:`CABLE_COLORS`, the same in every panel), used for its command
curve ``u_c`` over the trajectory and for its position in a small cross-section key.
Targets are pink and achieved tips near-black in every figure (:mod:`lab.viz.style`);
targets are counted from 1 along a trajectory. The functions take
:class:`lab.tracking.track.TrackResult` objects and return the figure.
"""

from __future__ import annotations

import numpy as np

from lab.viz.style import (
    ACHIEVED_COLOR,
    CABLE_COLORS,
    LIMIT_STYLE,
    achieved_kw,
    legend_outside,
    target_kw,
)

KEY_PT = 9  # font size of the cable key and its names: legible at a notebook's width


def _cable_key(ax, robot) -> None:
    """Cross-section of the arm (seen from the tip, y-z) with each cable's colour, in an axes
    of its own (never an inset over data), and the cables' names listed below it."""
    from matplotlib.patches import Circle

    R = 100 * robot.radius_m
    ax.add_patch(Circle((0, 0), R, fill=False, color="0.5"))
    for i, c in enumerate(robot.cables):
        y, z = 100 * c.via_points_m[-1, 1:]
        ax.plot(y, z, "o", color=CABLE_COLORS[i % 6], ms=8, label=c.name)
    ax.set_xlim(-1.5 * R, 1.5 * R)
    ax.set_ylim(-1.5 * R, 1.5 * R)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title("cables, seen\nfrom the tip", fontsize=KEY_PT)
    ax.legend(fontsize=KEY_PT, loc="upper center", bbox_to_anchor=(0.5, -0.04), frameon=False, handletextpad=0.2)


def plot_commands(ax, result, robot, legend: bool = True) -> None:
    """Motor commands (rad) against the target number (from 1), one colour per cable, with
    the motor limit u_max dashed and labelled."""
    number = np.arange(1, len(result.commands) + 1)
    for i, c in enumerate(robot.cables):
        ax.plot(number, result.commands[:, i], color=CABLE_COLORS[i % 6], lw=1.8, label=c.name)
    ax.axhline(robot.u_max_rad, **LIMIT_STYLE)
    ax.annotate(
        f"u_max {robot.u_max_rad:.3g} rad", (1.0, robot.u_max_rad), xycoords=("axes fraction", "data"),
        xytext=(-2, 2), textcoords="offset points", ha="right", va="bottom", fontsize=8, color="0.4",
    )  # fmt: skip
    ax.set_ylim(-0.1, 1.12 * robot.u_max_rad)
    ax.set_xlabel("target number [1]")
    ax.set_ylabel("motor command u [rad]")
    if legend:
        ax.legend(fontsize=7, loc="upper right", ncol=len(robot.cables))


def _is_loop(points) -> bool:
    """Whether a path (N, 3) ends next to its start (a circle, a square), not a spiral or helix:
    the gap about one of its steps (at most 1.1 of the median step)."""
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    return bool(len(points) > 2 and np.linalg.norm(points[-1] - points[0]) <= 1.1 * np.median(steps))


def _plane(ax, result, a: int, b: int, label: bool = True) -> None:
    t, p = 100 * result.targets_W, 100 * result.achieved_W
    closed = np.vstack([t, t[:1]]) if result.trajectory != "helix" and _is_loop(t) else t
    ax.plot(closed[:, a], closed[:, b], "-", **target_kw(lw=2.5, label="target" if label else None))
    ax.plot(p[:, a], p[:, b], ".", **achieved_kw(ms=3.5, label="achieved" if label else None))
    ax.set_xlabel(f"{'xyz'[a]} [cm]")
    ax.set_ylabel(f"{'xyz'[b]} [cm]")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)


def _equal_3d(ax, points_cm: np.ndarray, zoom: float) -> None:
    """Equal scales on a 3-D axes: a cube around ``points_cm`` (N, 3), axis labels in cm."""
    mid, half = (points_cm.max(0) + points_cm.min(0)) / 2, 0.55 * np.ptp(points_cm, axis=0).max()
    ax.set(
        xlim=(mid[0] - half, mid[0] + half),
        ylim=(mid[1] - half, mid[1] + half),
        zlim=(mid[2] - half, mid[2] + half),
        xlabel="x [cm]",
        ylabel="y [cm]",
        zlabel="z [cm]",
    )
    ax.set_box_aspect((1, 1, 1), zoom=zoom)


def _few_ticks(ax, n: int = 5, steps=None) -> None:
    """At most ``n`` ticks per 3-D axis (on multiples of ``steps``, MaxNLocator's): a
    foreshortened axis's labels ("16 17 18 19 20 21") otherwise run into one another."""
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(n, steps=steps))


def plot_tracking_row(results: dict, robot, title: str = ""):
    """Figure 3, one row: per trajectory (columns) the y-z projection of targets and achieved
    tip positions (cm), with the motor commands (rad) below.

    Parameters
    ----------
    results : dict
        ``{name: TrackResult}``.
    robot : RobotDescription
        The robot (its cables and u_max).
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    import matplotlib.pyplot as plt

    n = len(results)
    fig = plt.figure(figsize=(4.3 * n + 1.3, 7.2), layout="constrained")
    # a narrow last column holds the keys, so none sits on a shape or a command curve
    grid = fig.add_gridspec(2, n + 1, height_ratios=(1.6, 1), width_ratios=(1,) * n + (0.3,))
    for k, (name, res) in enumerate(results.items()):
        ax = fig.add_subplot(grid[0, k])
        _plane(ax, res, 1, 2)
        ax.set_title(
            f"{name}: mean error {100 * res.mean_error_m:.4f} cm\n(max {100 * res.max_error_m:.4f} cm, "
            f"{len(res.targets_W)} targets)",
            fontsize=10,
        )
        if k == 0:
            handles = ax.get_legend_handles_labels()
        plot_commands(fig.add_subplot(grid[1, k]), res, robot, legend=False)
    ax_legend = fig.add_subplot(grid[0, n])
    ax_legend.set_axis_off()
    ax_legend.legend(*handles, fontsize=KEY_PT, loc="center")
    _cable_key(fig.add_subplot(grid[1, n]), robot)
    if title:
        fig.suptitle(title)
    return fig


def plot_figure3(rows: dict, title: str = ""):
    """Figure 3 as in the paper: one row per condition, one column per trajectory, each panel
    the y-z projection of the targets (pink) and the achieved tip (dark), with its mean
    error. All panels share one scale (cm), so sizes and offsets compare across rows.

    Parameters
    ----------
    rows : dict
        ``{condition: {trajectory name: TrackResult}}``; every row has the same trajectories.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    import matplotlib.pyplot as plt

    names = list(next(iter(rows.values())))
    everything = np.vstack([100 * np.vstack([r.targets_W, r.achieved_W]) for rs in rows.values() for r in rs.values()])
    lo, hi = everything[:, 1:].min(0), everything[:, 1:].max(0)
    pad = 0.05 * (hi - lo).max()
    fig, axes = plt.subplots(
        len(rows),
        len(names),
        figsize=(3.6 * len(names), 3.5 * len(rows)),
        squeeze=False,
        layout="constrained",
        sharex=True,
        sharey=True,
    )
    for i, (condition, results) in enumerate(rows.items()):
        for j, name in enumerate(names):
            ax, res = axes[i, j], results[name]
            _plane(ax, res, 1, 2, label=i == 0 and j == 0)
            ax.set(xlim=(lo[0] - pad, hi[0] + pad), ylim=(lo[1] - pad, hi[1] + pad))
            ax.set_title(f"{name}: {100 * res.mean_error_m:.2g} cm mean", fontsize=10)
            if j == 0:
                ax.set_ylabel(f"{condition}\nz [cm]")
            else:
                ax.set_ylabel("")
            if i < len(rows) - 1:
                ax.set_xlabel("")
    axes[0, 0].legend(fontsize=8, loc="lower left")
    if title:
        fig.suptitle(title)
    return fig


def plot_helix(result, robot, title: str = ""):
    """Figure 4: the helix in 3-D (target pink, achieved dark), its y-z and x-z projections,
    and the motor commands.

    Parameters
    ----------
    result : TrackResult
        The tracked helix.
    robot : RobotDescription
        The robot (its cables and u_max).
    title : str, optional
        The figure's title (default: the number of targets).

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(15, 8), layout="constrained")
    grid = fig.add_gridspec(2, 3, height_ratios=(1.5, 1), width_ratios=(1.2, 1, 0.8))
    ax3 = fig.add_subplot(grid[0, 0], projection="3d")
    t, p = 100 * result.targets_W, 100 * result.achieved_W
    ax3.plot(*t.T, **target_kw(lw=2.5))
    ax3.plot(*p.T, ".", **achieved_kw(ms=3))
    _equal_3d(ax3, np.vstack([t, p]), zoom=0.85)
    ax3.set_proj_type("ortho")
    _few_ticks(ax3, 4, steps=(1, 2, 5, 10))  # whole or even centimetres: 16, 18, 20
    ax3.view_init(elev=15, azim=-35)
    ax3.legend(fontsize=8, loc="upper left")
    ax3.set_title("3-D")
    for k, ((a, b), name) in enumerate((((1, 2), "front view (y-z)"), ((0, 2), "side view (x-z)"))):
        ax = fig.add_subplot(grid[0, k + 1])
        _plane(ax, result, a, b, label=k == 0)
        ax.set_title(name)
    ax.set_aspect("auto")  # the helix is only ~1 cm deep along x
    ax.set_title("side view (x-z), x stretched")
    bottom = grid[1, :2].subgridspec(1, 2, width_ratios=(0.14, 1))
    _cable_key(fig.add_subplot(bottom[0, 0]), robot)  # beside the commands, not over them
    plot_commands(fig.add_subplot(bottom[0, 1]), result, robot, legend=False)
    ax_e = fig.add_subplot(grid[1, 2])
    ax_e.plot(np.arange(1, len(result.errors_m) + 1), 100 * result.errors_m, color=ACHIEVED_COLOR)
    ax_e.set_xlabel("target number [1]")
    ax_e.set_ylabel("error |achieved - target| [cm]")
    ax_e.set_title(f"mean {100 * result.mean_error_m:.4f} cm, max {100 * result.max_error_m:.4f} cm")
    ax_e.grid(alpha=0.3)
    fig.suptitle(title or f"helix, {len(t)} targets")
    return fig


def plot_paths_3d(results: dict, title: str = ""):
    """Figure 5: per path, its front view (y-z, equal scales: a circle stays round) with the
    target and the achieved tip, and under it the depth x of both along the path; cm. The
    panel title gives the mean and max 3-D error.

    Parameters
    ----------
    results : dict
        ``{name: TrackResult}``.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure: a front view and a depth strip per path, one legend beside them.
    """
    import matplotlib.pyplot as plt

    n = len(results)
    fig = plt.figure(figsize=(3.4 * n + 1.6, 5.6), layout="constrained")
    grid = fig.add_gridspec(2, n, height_ratios=(3.0, 1.0))
    for k, (name, res) in enumerate(results.items()):
        ax = fig.add_subplot(grid[0, k])
        _plane(ax, res, 1, 2, label=k == 0)
        ax.set_title(f"{name}: mean {100 * res.mean_error_m:.3f} cm,\nmax {100 * res.max_error_m:.3f} cm", fontsize=10)
        depth = fig.add_subplot(grid[1, k])
        number = np.arange(1, len(res.targets_W) + 1)
        depth.plot(number, 100 * res.targets_W[:, 0], "-", **target_kw(lw=2.5))
        depth.plot(number, 100 * res.achieved_W[:, 0], ".", **achieved_kw(ms=3))
        x_cm = 100 * np.concatenate([res.targets_W[:, 0], res.achieved_W[:, 0]])
        pad = max(0.5, 0.1 * np.ptp(x_cm))  # at least 1 cm shown: a flat path stays flat
        depth.set_ylim(x_cm.min() - pad, x_cm.max() + pad)
        depth.set_xlabel("target number [1]")
        depth.set_ylabel("depth x [cm]")
        depth.grid(alpha=0.3)
        if k == 0:
            handles = ax.get_lines()
    legend_outside(fig, handles)
    if title:
        fig.suptitle(title)
    return fig
