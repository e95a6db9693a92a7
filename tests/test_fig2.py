"""Figure 2 (:func:`lab.viz.plot_square_frames`): the arm at frames along the square, each
motor's angle in its colour, on a tiny case."""

from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from lab.control import CommandSet, trajectories  # noqa: E402
from lab.fem import solve_static  # noqa: E402
from lab.viz import plot_square_frames  # noqa: E402
from lab.viz.square_frames import frame_indices  # noqa: E402
from lab.viz.tracking import CABLE_COLORS  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def test_frames_spread_along_the_path():
    np.testing.assert_array_equal(frame_indices(100, 8), [0, 12, 25, 37, 50, 62, 75, 87])
    np.testing.assert_array_equal(frame_indices(8, 4), [0, 2, 4, 6])
    with pytest.raises(ValueError):
        frame_indices(3, 4)


def test_figure2_has_a_panel_and_motor_bars_per_frame(coarse_fem, tmp_path):
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgb

    robot = coarse_fem.robot
    targets = trajectories.builtin("square", 8)
    # any allowed commands do for the drawing: a smooth loop through the command set
    phase = np.linspace(0, 2 * np.pi, len(targets), endpoint=False)[:, None]
    commands = 1.2 + 0.8 * np.sin(phase + np.array([0.0, 2.1, 4.2]))
    assert all(CommandSet.from_robot(robot).contains(u) for u in commands)
    fig = plot_square_frames(coarse_fem, targets, commands, n_frames=4, ncols=2, title="tiny")
    panels = [ax for ax in fig.axes if ax.name == "3d"]
    # frames and targets both counted from 1
    titles = [f"frame {k + 1}: target {i + 1} of 8" for k, i in enumerate((0, 2, 4, 6))]
    assert [ax.get_title() for ax in panels] == titles
    bars = [ax for ax in fig.axes if ax.name != "3d" and ax.patches]
    assert len(bars) == 4
    for ax, i in zip(bars, (0, 2, 4, 6)):
        np.testing.assert_allclose([p.get_width() for p in ax.patches], commands[i])  # each motor's angle ...
        assert [p.get_facecolor()[:3] for p in ax.patches] == [to_rgb(c) for c in CABLE_COLORS[:3]]  # ... its colour
    # the drawn arm is the equilibrium at the frame's command (its tip marker, from plot_arm)
    tip = solve_static(coarse_fem, commands[2]).p_tip_W
    marker = [np.ravel(ln.get_data_3d()) for ln in panels[1].lines if ln.get_marker() == "o"]
    assert len(marker) == 1
    np.testing.assert_allclose(marker[0], 100 * tip, atol=1e-4)  # cm
    strip = [ax for ax in fig.axes if ax.get_xlabel().startswith("target number")]
    assert len(strip) == 1 and len([ln for ln in strip[0].lines if len(ln.get_xdata()) == 8]) == robot.n_cables
    assert strip[0].get_xlim() == (1, 8)  # targets counted from 1
    # the tracking face-on: every target of the square, each frame's target numbered
    (front,) = [ax for ax in fig.axes if ax.get_xlabel() == "y [cm]"]
    assert sorted(t.get_text() for t in front.texts) == ["1", "2", "3", "4"]
    key = [ax.get_legend() for ax in fig.axes if not ax.axison and ax.get_legend() is not None]
    assert len(key) == 1 and any(t.get_text().startswith("motor limit u_max") for t in key[0].get_texts())
    assert "tiny" in fig._suptitle.get_text()
    path = tmp_path / "fig2_square.png"
    fig.savefig(path, dpi=60)
    assert path.stat().st_size > 10_000
    plt.close(fig)
    with pytest.raises(ValueError):
        plot_square_frames(coarse_fem, targets, commands[:5])
