"""Figure 1 (the set-up drawn from the description) and chapter 01's interactive arm
(:class:`lab.viz.ArmExplorer`), its callbacks exercised headless."""

from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from lab.description import load_robot  # noqa: E402
from lab.errors import InputError  # noqa: E402
from lab.fem import ArmFEM, solve_static  # noqa: E402
from lab.rig.hardware_config import load_hardware_config  # noqa: E402
from lab.viz import ArmExplorer, plot_setup  # noqa: E402
from lab.viz import sliders as sliders_module  # noqa: E402
from lab.viz.setup import setup_geometry  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
#: The shipped robots driven by cables on spools, which the setup drawing shows (not the pneumatic arm).
ROBOTS = [p for p in sorted((ROOT / "lab" / "robots").glob("*.toml")) if "[[cables]]" in p.read_text()]


@pytest.mark.parametrize("path", ROBOTS, ids=[p.stem for p in ROBOTS])
def test_setup_draws_every_cable_route_spool_and_marker(path):
    import matplotlib.pyplot as plt

    robot = load_robot(path)
    geo = setup_geometry(robot)
    assert len(geo["routes"]) == robot.n_cables
    for route, cable in zip(geo["routes"], robot.cables):
        np.testing.assert_array_equal(route[0], cable.anchor_m)  # from the anchor ...
        np.testing.assert_array_equal(route[-1], cable.via_points_m[-1])  # ... to where it is tied off
    # spools behind the base plate, and no two in the same place (six-cable: shared anchors)
    assert np.all(geo["spools"][:, 0] < 0)
    d = np.linalg.norm(geo["spools"][:, None] - geo["spools"][None], axis=2) + np.eye(robot.n_cables)
    assert d.min() >= 2 * robot.spool_radius_m
    fig, (ax_side, ax_top, ax_face) = plot_setup(robot)
    # side view: per cable its route, eyelets and tie-off plus the spool link; then the tip
    tip_lines = [ln for ln in ax_side.lines if ln.get_label() == "tip marker"]
    assert len(tip_lines) == 1
    np.testing.assert_allclose(np.ravel(tip_lines[0].get_data()), 100 * robot.p_tip_marker_W[[0, 2]])
    legend = [t.get_text() for t in ax_side.get_legend().get_texts()]
    assert [c.name for c in robot.cables] == legend[: robot.n_cables]
    plt.close(fig)


def test_setup_shows_the_base_markers_of_a_hardware_configuration():
    import matplotlib.pyplot as plt

    robot = load_robot("three-cable")
    cfg = load_hardware_config(ROOT / "lab" / "rigs" / "hardware-example.toml", robot)
    fig, (ax_side, _, ax_face) = plot_setup(robot, cfg.natnet.base_positions_W_m)
    markers = [ln for ln in ax_side.lines if ln.get_label().startswith("base markers")]
    assert len(markers) == 1
    np.testing.assert_allclose(markers[0].get_xdata(), 100 * cfg.natnet.base_positions_W_m[:, 0])
    plt.close(fig)


@pytest.fixture(scope="module")
def explorer():
    fem = ArmFEM(load_robot("three-cable"), n_rings=1, n_axial=6)
    return ArmExplorer(fem, levels=2)


def test_explorer_draws_the_exact_equilibrium(explorer):
    import matplotlib.pyplot as plt

    u = np.array([1.2, 0.4, 0.1])
    out = explorer.update(u)
    cold = solve_static(explorer.fem, u)
    assert out["safe"]
    np.testing.assert_allclose(out["p_tip_W"], cold.p_tip_W, atol=1e-6)  # not an interpolation
    assert explorer.fig is not None and f"{100 * cold.p_tip_W[0]:.1f}" in explorer.fig._suptitle.get_text()
    # the kept equilibria make a nearby command cheaper than a cold solve
    near = explorer.update(u + 0.05, draw=False)
    assert near["iterations"] < cold.iterations
    plt.close(explorer.fig)


def test_explorer_refuses_unsafe_and_malformed_commands(explorer):
    before = len(explorer.u_cache)
    out = explorer.update(np.full(3, 3.0))  # 9 rad in total: beyond the safety limit
    assert not out["safe"] and out["p_tip_W"] is None and len(explorer.u_cache) == before
    assert "unsafe" in explorer.fig._suptitle.get_text()
    with pytest.raises(InputError, match="needs 3 motor angles"):
        explorer.update([1.0, 2.0])


def test_explorer_without_a_front_end_says_so(explorer, capsys, monkeypatch):
    monkeypatch.setattr(sliders_module, "widgets_available", lambda: False)
    assert explorer.widget() is None
    assert "no widget front end" in capsys.readouterr().out


def test_explorer_sliders_drive_the_callback(explorer, monkeypatch):
    pytest.importorskip("ipywidgets")
    monkeypatch.setattr(sliders_module, "widgets_available", lambda: True)
    monkeypatch.setattr(explorer, "last", None)  # nothing solved yet: the sliders start at zero
    box = explorer.widget()
    sliders = box.children[: explorer.robot.n_cables]
    assert [s.description for s in sliders] == [f"{c.name} [rad]" for c in explorer.robot.cables]
    sliders[0].value = 1.5  # what dragging the first slider does
    np.testing.assert_allclose(explorer.last["u_motor"], [1.5, 0.0, 0.0])
    assert "ms" in box.children[explorer.robot.n_cables].value  # the status line reports the solve


def test_explorer_widget_carries_the_image_it_drew(explorer, monkeypatch):
    """Where no widget can be shown (a saved notebook, the site's recorded run) the sliders'
    output is the arm they drew: the widget's display carries its image beside the view."""
    import base64

    from IPython.core.formatters import DisplayFormatter

    pytest.importorskip("ipywidgets")
    monkeypatch.setattr(sliders_module, "widgets_available", lambda: True)
    box = explorer.widget(live=False)
    data, _ = DisplayFormatter().format(box)
    assert "application/vnd.jupyter.widget-view+json" in data  # a front end with widgets shows the sliders
    png = base64.b64decode(data["image/png"])
    assert png.startswith(b"\x89PNG") and png == box.children[-1].value  # the arm they drew last
    explorer.sliders[0].value = 1.0  # a move redraws it, and a later display carries the new one
    assert base64.b64decode(DisplayFormatter().format(box)[0]["image/png"]) == box.children[-1].value != png
    assert "image/png" not in DisplayFormatter().format(sliders_module.still_box(list(box.children)))[0]


def test_explorer_sliders_start_at_the_pose_shown(explorer, monkeypatch):
    """The sliders start at the last command solved (what the view shows first), not at zero
    beside a bent arm."""
    pytest.importorskip("ipywidgets")
    monkeypatch.setattr(sliders_module, "widgets_available", lambda: True)
    u_mixed = explorer.robot.u_max_rad * np.array([2 / 3, 1 / 3, 1 / 6])
    explorer.update(u_mixed, draw=False)
    box = explorer.widget(live=False)
    values = [s.value for s in box.children[: explorer.robot.n_cables]]
    np.testing.assert_allclose(values, u_mixed, atol=0.05)  # to the sliders' step
    np.testing.assert_allclose(explorer.last["u_motor"], values)  # the first view: that pose
