import itertools
import tomllib

import numpy as np
import pytest

from lab.data.designs import grid_commands
from lab.description import ROBOTS_DIR, DescriptionError, load_robot, parse_robot
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static


def _data(name="three-cable"):
    return tomllib.loads((ROBOTS_DIR / f"{name}.toml").read_text())


def test_safety_rule_keeps_308_of_the_7x7x7_grid(three_cable):
    assert len(grid_commands(three_cable, 7)) == 308
    axis = np.linspace(0, three_cable.u_max_rad, 7)
    idx = np.array(list(itertools.product(range(7), repeat=3)))
    # The documented rule: discard exactly the commands whose grid indices sum to >= 14.
    assert np.array_equal(three_cable.is_safe(axis[idx]), idx.sum(1) < 14)


def test_six_cable_grid_count():
    robot = load_robot("six-cable")
    assert robot.n_cables == 6
    assert len(grid_commands(robot, 5)) == 15415
    short = [c for c in robot.cables if c.name.endswith("short")]
    assert all(c.via_points_m[-1, 0] == pytest.approx(robot.length_m / 2) for c in short)


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda d: d["material"].pop("youngs_modulus_pa"), "material.youngs_modulus_pa"),
        (lambda d: d["material"].update(youngs_modulus_pa=-5.0), "material.youngs_modulus_pa"),
        (lambda d: d["material"].update(poisson_ratio=0.5), "material.poisson_ratio"),
        (lambda d: d["actuation"].update(u_max_rad="3"), "actuation.u_max_rad"),
        (lambda d: d["body"].update(length_m=float("nan")), "body.length_m"),
        (lambda d: d["tip_marker"].update(position_m=[0.2, 0.0]), "tip_marker.position_m"),
        (lambda d: d["cables"][1].update(offset_m=0.05), "cables[1]"),
        (lambda d: d["cables"][0].update(stations_m=[0.08, 0.04]), "cables[0]"),
        (lambda d: d["safety"]["limits"][0].update(cables=[0, 7]), "safety.limits[0].cables"),
        (lambda d: d.update(format_version=99), "format_version"),
    ],
)
def test_bad_description_names_the_field(mutate, field):
    data = _data()
    mutate(data)
    with pytest.raises(DescriptionError, match=field.replace("[", r"\[").replace("]", r"\]")):
        parse_robot(data)


def test_hash_tracks_content(three_cable):
    import dataclasses

    assert three_cable.sha256 == load_robot("three-cable").sha256
    softer = dataclasses.replace(three_cable, youngs_modulus_pa=20e3)
    assert softer.sha256 != three_cable.sha256


def test_bad_files(tmp_path):
    with pytest.raises(DescriptionError, match="unknown robot"):
        load_robot("four-cable")
    bad = tmp_path / "bad.toml"
    bad.write_text("name = [unclosed")
    with pytest.raises(DescriptionError, match="not valid TOML"):
        load_robot(bad)


def test_user_description_works_downstream(tmp_path):
    """A shorter arm with four cables, written by a user, simulates like a shipped one."""
    text = (ROBOTS_DIR / "three-cable.toml").read_text()
    text = text.replace("length_m = 0.20", "length_m = 0.15").replace("0.16, 0.20]", "0.15]")
    text = text.replace("position_m = [0.20, 0.0, 0.0]", "position_m = [0.15, 0.0, 0.0]")
    text = text.replace("cables = [0, 1, 2]", "cables = [0, 1, 2, 3]")
    text += '\n[[cables]]\nname = "extra"\nangle_deg = 0.0\noffset_m = 0.012\nstations_m = [0.05, 0.10, 0.15]\n'
    path = tmp_path / "mine.toml"
    path.write_text(text)
    robot = load_robot(path)
    assert robot.n_cables == 4 and robot.length_m == 0.15
    fem = ArmFEM(robot, n_rings=1, n_axial=8)
    sol = solve_static(fem, [0.0, 0.0, 0.0, 2.0], sensitivity=True)
    assert sol.converged and sol.J_tip_u.shape == (3, 4)
    # The extra cable sits at angle 0 (+y): pulling it bends the tip towards +y.
    assert sol.p_tip_W[1] > 0.01


def test_check_command(three_cable):
    with pytest.raises(ValueError, match="finite"):
        three_cable.check_command([np.nan, 0, 0])
    with pytest.raises(ValueError, match="outside"):
        three_cable.check_command([3.5, 0, 0])
    with pytest.raises(ValueError, match="safety"):
        three_cable.check_command([3.0, 3.0, 3.0])
    with pytest.raises(ValueError, match="3 motor angles"):
        three_cable.check_command([1.0, 1.0])
