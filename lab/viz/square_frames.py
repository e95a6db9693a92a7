"""Figure 2 of the paper: the arm following the square, frame by frame.

The paper's Figure 2 shows the three-cable robot at several moments while it follows a
square-shaped tip trajectory, each motor coloured after its control input. Here each
frame is the arm's FEM equilibrium at the command sent for one target (the simulated
robot), drawn in 3-D (orthographic, equal scales) with the square (pink), the tip's trail
so far (near-black) and the current target; every motor keeps one colour
(:data:`lab.viz.style.CABLE_COLORS`, as in Figure 3): its cable in the arm, its bar (the
angle u, rad, under each frame) and its command curve along the whole trajectory in the
strip below, where the frames are marked. The tracking itself is seen face-on in a front
view (y-z) beside the frames: the square, the whole trail and each frame's target,
numbered as the frames are. Frames and targets count from 1. Positions in cm, frame W
(x along the arm, z up).
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.viz.arm import arm_geometry, plot_arm
from lab.viz.style import CABLE_COLORS, LIMIT_STYLE, TARGET_COLOR, achieved_kw, target_kw

__all__ = ["TICK_PT", "frame_indices", "solve_frames", "plot_square_frames"]

#: Font size (pt) of the 3-D panels' tick and axis labels and the bars: the figure is about
#: 12 in wide and shown about 1000 px wide in a notebook, where 10 pt is about 11 px tall.
TICK_PT = 10


def frame_indices(n_targets: int, n_frames: int) -> np.ndarray:
    """``n_frames`` indices (int, 0-based) spread evenly along a closed path of ``n_targets``
    points, starting at the first."""
    if not 1 <= n_frames <= n_targets:
        raise InputError(f"need 1 <= n_frames <= n_targets, got {n_frames} frames of {n_targets} targets")
    return np.floor(np.arange(n_frames) * n_targets / n_frames).astype(int)


def solve_frames(fem, u_frames) -> tuple[np.ndarray, np.ndarray]:
    """FEM equilibria at the commands ``u_frames`` (F, m) rad, each warm-started from the
    previous one: states ``q`` (F, n_free) m and tips ``p_tip_W`` (F, 3) m."""
    from lab.fem import solve_static

    q, tips, q_prev = [], [], None
    for u in np.atleast_2d(np.asarray(u_frames, float)):
        sol = solve_static(fem, u, q0=q_prev)
        q_prev = sol.q
        q.append(sol.q)
        tips.append(sol.p_tip_W)
    return np.array(q), np.array(tips)


def _limit_label(robot) -> str:
    return f"motor limit u_max = {robot.u_max_rad:.3g} rad"


def _motor_bars(ax, robot, u_motor) -> None:
    """The angles u (rad) of one frame: a horizontal bar per motor in its colour, u_max dashed."""
    n = len(u_motor)
    ax.barh(range(n), u_motor, color=[CABLE_COLORS[k % 6] for k in range(n)], height=0.7)
    for k, u in enumerate(u_motor):
        ax.text(u + 0.04, k, f"{u:.2f}", va="center", ha="left", fontsize=TICK_PT)
    ax.axvline(robot.u_max_rad, **LIMIT_STYLE, label=_limit_label(robot))
    ax.set_xlim(0, 1.02 * robot.u_max_rad)
    ax.set_ylim(n - 0.5, -0.5)  # first motor on top, as in the legend
    ax.set_yticks([])
    ax.tick_params(labelsize=TICK_PT, pad=1)
    ax.set_xlabel("motor angle u [rad]", fontsize=TICK_PT, labelpad=1)
    ax.spines[["top", "right"]].set_visible(False)


def _frame_3d(ax, fem, q, geo, targets, done, i, lo, hi, view) -> None:
    """One frame: the arm at ``q``, its cables in their colours, the square, the trail ``done``
    (cm) and the current target ``i``, orthographic with equal scales."""
    plot_arm(ax, fem, q, unit="cm", foam_alpha=0.18, linewidth=0.1, geometry=geo)
    for c, line in enumerate(geo.cables_W):  # each motor's cable in its colour
        ax.plot(*(100 * line).T, color=CABLE_COLORS[c % 6], lw=2.2, zorder=3)
    closed = 100 * np.vstack([targets, targets[:1]])
    ax.plot(*closed.T, **target_kw(lw=1.6, zorder=2))
    ax.plot(*done.T, **achieved_kw(lw=1.4, zorder=4))
    ax.plot(*(100 * targets[i, :, None]), "x", color=TARGET_COLOR, ms=8, mew=2, zorder=5)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]))
    ax.set_zlim(lo[2], hi[2])
    ax.set_proj_type("ortho")  # no perspective: the square stays a square, sizes compare
    ax.view_init(*view)
    ax.set_box_aspect(hi - lo, zoom=1.2)  # equal scales
    ax.locator_params(nbins=4)
    ax.tick_params(labelsize=TICK_PT, pad=0)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.label.set_size(TICK_PT)
        axis.labelpad = -1


def _front_view(ax, targets, trail, idx) -> None:
    """The tracking face-on (y-z, cm, equal scales): the square, the trail, each frame's
    target numbered as its frame."""
    closed = 100 * np.vstack([targets, targets[:1]])
    ax.plot(closed[:, 1], closed[:, 2], "-", **target_kw(lw=2.2, label="target square"))
    ax.plot(100 * trail[:, 1], 100 * trail[:, 2], ".", **achieved_kw(ms=4, label="tip (achieved)"))
    for k, i in enumerate(idx):
        y, z = 100 * targets[i, 1:]
        ax.plot(y, z, "x", color=TARGET_COLOR, ms=8, mew=2, zorder=5)
        ax.annotate(str(k + 1), (y, z), xytext=(5, 4), textcoords="offset points", fontsize=10, fontweight="bold")
    ax.set_aspect("equal")
    ax.margins(0.12)
    ax.set_xlabel("y [cm]")
    ax.set_ylabel("z [cm]")
    ax.set_title("the square face-on (y-z), frames numbered", fontsize=10)
    ax.grid(alpha=0.3)


def plot_square_frames(
    fem,
    targets_W,
    commands,
    *,
    achieved_W=None,
    n_frames: int = 4,
    ncols: int = 2,
    view=(22.0, -140.0),
    title: str = "",
):
    """Figure 2: the arm of ``fem`` at ``n_frames`` points of the trajectory ``targets_W``,
    commanded ``commands``, and the tracking seen face-on.

    Parameters
    ----------
    fem : ArmFEM
        The arm's FEM (:class:`lab.fem.ArmFEM`).
    targets_W : array_like, shape (N, 3)
        The trajectory (m, frame W).
    commands : array_like, shape (N, m)
        Motor commands (rad).
    achieved_W : array_like, shape (N, 3), optional
        The recorded tips (m), drawn as the trail (default: the FEM tips of the frames only).
    n_frames, ncols : int, optional
        Frames drawn; frames per row.
    view : tuple of float, optional
        (elevation, azimuth) of the 3-D frames in degrees.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        One 3-D axes per frame (title ``"frame k: target i of N"``, both counted from 1),
        each with a bar axes of the motor angles under it; the front view (y-z) of the
        square and the trail beside them; the command strip (commands against the target
        number, frames marked) along the bottom; one key beside the strip.
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    targets, u_all = np.asarray(targets_W, float), np.asarray(commands, float)
    if targets.ndim != 2 or targets.shape[1] != 3 or u_all.shape != (len(targets), fem.robot.n_inputs):
        raise InputError(
            f"need targets (N, 3) m and commands (N, {fem.robot.n_inputs}) rad, got {targets.shape}, {u_all.shape}"
        )
    robot, idx = fem.robot, frame_indices(len(targets), n_frames)
    q, tips = solve_frames(fem, u_all[idx])
    geos = [arm_geometry(fem, qk) for qk in q]
    trail = np.asarray(achieved_W, float) if achieved_W is not None else None
    # one box for every frame (arm and square), so that the frames compare directly
    pts = 100 * np.vstack([*(g.nodes_W for g in geos), targets])
    lo, hi = pts.min(0) - 0.5, pts.max(0) + 0.5

    ncols = min(ncols, n_frames)
    nrows = -(-n_frames // ncols)
    # a fixed layout: constrained layout does not see the labels of 3-D axes
    fig = plt.figure(figsize=(3.9 * ncols + 4.6, 4.3 * nrows + 2.6))
    grid = fig.add_gridspec(
        nrows + 1, ncols + 1, height_ratios=(*[1.0] * nrows, 0.55), width_ratios=(*[1.0] * ncols, 1.15),
        left=0.04, right=0.98, bottom=0.08, top=0.9, hspace=0.32, wspace=0.16,
    )  # fmt: skip
    for k, (i, geo) in enumerate(zip(idx, geos)):
        cell = grid[k // ncols, k % ncols].subgridspec(2, 1, height_ratios=(5, 1), hspace=0.32)
        ax = fig.add_subplot(cell[0], projection="3d", computed_zorder=False)
        done = 100 * (trail[: i + 1] if trail is not None else tips[: k + 1])
        _frame_3d(ax, fem, q[k], geo, targets, done, i, lo, hi, view)
        ax.set_title(f"frame {k + 1}: target {i + 1} of {len(targets)}", fontsize=TICK_PT + 2, pad=-2)
        _motor_bars(fig.add_subplot(cell[1]), robot, u_all[i])
    _front_view(fig.add_subplot(grid[:nrows, ncols]), targets, trail if trail is not None else tips, idx)

    strip = fig.add_subplot(grid[nrows, :ncols])
    number = np.arange(1, len(targets) + 1)  # targets counted from 1, as in the frames' titles
    for c, cable in enumerate(robot.cables):
        strip.plot(number, u_all[:, c], color=CABLE_COLORS[c % 6], lw=1.8, label=cable.name)
    strip.axhline(robot.u_max_rad, **LIMIT_STYLE)
    for k, i in enumerate(idx):
        strip.axvline(i + 1, color="0.4", lw=0.8, ls=":")
        strip.scatter([i + 1] * len(robot.cables), u_all[i], c=CABLE_COLORS[: len(robot.cables)], s=18, zorder=3)
        strip.annotate(
            str(k + 1), (i + 1, 1.0), xycoords=("data", "axes fraction"), xytext=(2, -2), textcoords="offset points",
            ha="left", va="top", fontsize=9, fontweight="bold",
        )  # fmt: skip
    strip.set(xlim=(1, len(targets)), ylim=(-0.1, 1.12 * robot.u_max_rad))
    strip.set_xlabel("target number along the square (frames marked) [1]")
    strip.set_ylabel("motor command u [rad]")
    keys = [
        Line2D([], [], **target_kw(lw=1.6, label="target square")),
        Line2D([], [], color=TARGET_COLOR, ls="", marker="x", ms=8, mew=2, label="the frame's target"),
        Line2D([], [], **achieved_kw(lw=1.4, label="tip so far (achieved)")),
        *(Line2D([], [], color=CABLE_COLORS[c % 6], lw=2.2, label=cable.name) for c, cable in enumerate(robot.cables)),
        Line2D([], [], **LIMIT_STYLE, label=_limit_label(robot)),
    ]
    key = fig.add_subplot(grid[nrows, ncols])
    key.set_axis_off()
    key.legend(handles=keys, loc="center", fontsize=TICK_PT - 1, frameon=False)
    if title:
        fig.suptitle(title)
    return fig
