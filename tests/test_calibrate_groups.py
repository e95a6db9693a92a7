"""``calibrate --fit GROUPS``: the parameter groups (density among them), a robot of tension
tendons, every marker in the data; the new sensitivities against central differences."""

import dataclasses
import re

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.cli import main
from lab.data.dataset import write_dataset
from lab.description import load_robot
from lab.errors import InputError
from lab.fem.model import ArmFEM
from lab.fem.solve.parameter_layout import DEFAULT_GROUPS, GROUPS, ParameterError, ParameterLayout, parse_groups
from lab.fem.solve.parameters import ParametrisedFEM
from lab.fem.solve.statics import solve_static
from lab.transfer import calibrate, calibrated_toml
from lab.transfer.calibrate import default_groups

MESH = dict(n_rings=1, n_axial=6)
ROBOTS = __import__("pathlib").Path(__file__).resolve().parents[1] / "lab" / "robots"


def tension_toml(path, markers=()) -> str:
    """The three-cable description with every cable pulled by tension (at most 3 N), no
    [actuation] and no angle safety rule; ``markers`` (name, [x, y, z]) added."""
    text = (ROBOTS / "three-cable.toml").read_text()
    text = re.sub(r"\[actuation\].*?(?=\[\[cables\]\])", "", text, flags=re.S)
    text = re.sub(r"\[\[safety\.limits\]\].*", "", text, flags=re.S)
    text = text.replace('name = "three-cable"', 'name = "three-tendon"')
    text = text.replace(
        "stations_m = [0.04, 0.08, 0.12, 0.16, 0.20]\n",
        'stations_m = [0.04, 0.08, 0.12, 0.16, 0.20]\ncontrol = "tension"\ntension_max_n = 3.0\n',
    )
    for name, p in markers:
        text += f'\n[[markers]]\nname = "{name}"\nposition_m = {list(p)}\n'
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def tendons(tmp_path_factory):
    return load_robot(tension_toml(tmp_path_factory.mktemp("tendons") / "three-tendon.toml"))


def test_groups_parse_and_the_default_layout_is_todays(three_cable):
    assert parse_groups("density, softness") == ("softness", "density")
    with pytest.raises(InputError, match="unknown fit group 'stiffness'; valid groups: softness, gradient"):
        parse_groups("softness,stiffness")
    lay = ParameterLayout(tuple(c.name for c in three_cable.cables))
    assert lay.groups == DEFAULT_GROUPS and lay.size == 12 and lay.slack == slice(9, 12)
    full = ParameterLayout(lay.cable_names, groups=GROUPS, slack_cables=(0, 2))
    assert full.size == 3 + 6 + 2 + 1 and full.names[-3:] == ["slack_m[top]", "slack_m[lower-right]", "density_factor"]
    th = full.pack(0.5, (0.1, 0.2), None, [1e-3, 2e-3, 3e-3], density=1.3)
    v = full.unpack(th)
    assert v["density"] == 1.3 and np.allclose(v["slack_m"], [1e-3, 0, 3e-3]) and np.isclose(v["softness"], 0.5)
    small = ParameterLayout(lay.cable_names, groups=("softness", "density"))
    v = small.unpack(small.pack(2.0, density=0.7))
    assert v["gradient"] is None and v["slack_m"] is None and v["density"] == 0.7 and not v["via_shift_m"].any()
    assert default_groups(three_cable) == DEFAULT_GROUPS


def test_density_group_scales_the_gravity_load(three_cable):
    pf = ParametrisedFEM(three_cable, **MESH, groups=("softness", "density"))
    th = pf.layout.pack(1.0, density=2.0)
    assert pf.description(th).density_kg_m3 == 2 * three_cable.density_kg_m3
    assert np.allclose(pf.fem(th).f_gravity_W, 2 * ArmFEM(three_cable, **MESH).f_gravity_W, rtol=1e-14)
    with pytest.raises(ParameterError, match="density factor"):
        pf.fem(pf.layout.pack(1.0, density=-0.5))


#: Central-difference steps per group: small enough for the truncation error, large enough
#: that the solver (its force tolerance scales with the weight) moves off its start.
STEPS = {"softness": 1e-6, "gradient": 1e-6, "eyelets": 1e-7, "slack": 1e-7, "density": 1e-4}


def _check_fd(pf, th, u):
    sol = pf.solve(th, u, tol_step_m=1e-10)
    _, dq_dth, _, J_th = pf.sensitivities(th, sol.q, u)
    for group in pf.layout.groups:
        idx = np.arange(pf.layout.size)[pf.layout.block(group)]

        def tip(v, idx=idx):
            t = th.copy()
            t[idx] = v
            return pf.solve(t, u, sol.q, tol_step_m=1e-10).p_tip_W

        J_fd = fd_jacobian(tip, th[idx], STEPS[group])
        err = np.abs(J_fd - J_th[:, idx]).max() / np.abs(J_fd).max()
        assert err < 1e-6, f"{group}: relative error {err:.2e}"
        assert np.all(np.abs(J_fd).max(axis=0) > 1e-4)  # every parameter moves the tip


def test_density_sensitivity_matches_central_differences(three_cable):
    pf = ParametrisedFEM(three_cable, **MESH, groups=GROUPS)
    th = pf.layout.pack(0.8, (0.2, -0.3), [[0, 2e-4, -1e-4], [0, 0, 1e-4], [0, -1e-4, 0]], [0, 1e-3, 5e-4], 1.4)
    _check_fd(pf, th, np.array([1.5, 1.2, 1.0]))


def test_tension_tendons_eyelet_and_density_sensitivities_match_central_differences(tendons):
    pf = ParametrisedFEM(tendons, **MESH, groups=("softness", "gradient", "eyelets", "density"))
    assert "slack" not in " ".join(pf.layout.names)
    th = pf.layout.pack(0.9, (0.1, 0.1), [[0, 2e-4, -1e-4], [0, 0, 1e-4], [0, -1e-4, 0]], density=1.2)
    _check_fd(pf, th, np.array([1.0, 0.6, 0.3]))


def test_slack_is_refused_for_tension_tendons(tendons):
    assert "slack" not in default_groups(tendons)
    with pytest.raises(ParameterError, match="fit group 'slack' needs an angle-controlled cable"):
        ParametrisedFEM(tendons, **MESH, groups=DEFAULT_GROUPS)


def test_default_fit_is_the_fit_of_todays_groups(three_cable):
    """The default groups give bit for bit the fit of today's set, named explicitly."""
    heavy = dataclasses.replace(three_cable, youngs_modulus_pa=36e3)
    u = np.array([[1.0, 0.2, 0.0], [0.0, 1.5, 0.5], [0.3, 0.0, 2.0], [1.0, 1.0, 1.0], [2.0, 0.0, 0.5]])
    fem = ArmFEM(heavy, **MESH)
    y = np.array([solve_static(fem, ui).p_tip_W for ui in u])
    a = calibrate(three_cable, u, y, **MESH, noise_m=1e-4)
    b = calibrate(three_cable, u, y, **MESH, noise_m=1e-4, groups="softness,gradient,eyelets,slack")
    assert a.layout == b.layout and a.layout.size == 12
    assert np.array_equal(a.theta, b.theta) and np.array_equal(a.covariance, b.covariance)
    assert a.summary()["fit_groups"] == list(DEFAULT_GROUPS) and a.summary()["markers"] == ["tip"]


def emulate(robot, u, density_factor, softness=1.0):
    true = dataclasses.replace(
        robot, density_kg_m3=robot.density_kg_m3 * density_factor, youngs_modulus_pa=robot.youngs_modulus_pa * softness
    )
    fem = ArmFEM(true, **MESH)
    return np.array([solve_static(fem, ui, check_command=False).y_W.ravel() for ui in u])


def test_density_recovered_from_a_robot_reaching_sideways(three_cable):
    """The arm along +x under gravity along -z: 40 % heavier foam than described, found within a few %."""
    assert np.allclose(three_cable.gravity_m_s2, [0, 0, -9.81])
    u = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5], [0.8, 0.8, 0.0], [2.0, 0.5, 0.0]])
    y = emulate(three_cable, u, 1.4, softness=0.9)
    res = calibrate(three_cable, u, y, **MESH, noise_m=1e-5, groups="softness,density")
    v = res.values
    assert res.converged and abs(v["density"] / 1.4 - 1) < 0.03 and abs(v["softness"] / 0.9 - 1) < 0.03
    text = calibrated_toml(three_cable, res)
    assert f"density_kg_m3 = {three_cable.density_kg_m3 * v['density']!r}" in text
    assert res.check["model_discrepancy"] is False


def test_cli_fits_softness_and_density_of_a_tension_robot(tendons, tmp_path, capsys):
    robot_file = tension_toml(tmp_path / "three-tendon.toml")
    u = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.5, 0.5], [0.5, 0.0, 2.5], [1.0, 1.0, 1.0], [3.0, 1.0, 0.0]])
    y = emulate(tendons, u, 1.3, softness=1.2)
    real = tmp_path / "real.csv"
    write_dataset(real, u, y, {"robot": {"name": "three-tendon"}})
    out = tmp_path / "asbuilt.toml"
    argv = ["calibrate", "--robot", str(robot_file), str(real), "--fit", "softness,density", "--out", str(out)]
    assert main([*argv, "--n-rings", "1", "--n-axial", "6", "--noise-m", "1e-5"]) == 0
    err = capsys.readouterr().err
    assert "calibrating softness, density" in err
    built = load_robot(out)
    assert abs(built.density_kg_m3 / (1.3 * tendons.density_kg_m3) - 1) < 0.03
    assert abs(built.youngs_modulus_pa / (1.2 * tendons.youngs_modulus_pa) - 1) < 0.03
    assert built.all_angle is False and built.spool_radius_m is None and built.cables[0].tension_max_n == 3.0


def test_cli_unknown_or_impossible_group_exits_2(tmp_path, capsys):
    robot_file = tension_toml(tmp_path / "three-tendon.toml")
    real = tmp_path / "real.csv"
    write_dataset(real, np.zeros((2, 3)), np.zeros((2, 3)), {})
    out = tmp_path / "c.toml"
    cases = [
        (["--fit", "softness,stiffness"], "unknown fit group 'stiffness'; valid groups: softness, gradient, eyelets"),
        (["--robot", str(robot_file), "--fit", "softness,slack"], "--fit slack: three-tendon has no angle-controlled"),
    ]
    for args, message in cases:
        assert main(["calibrate", str(real), *args, "--out", str(out)]) == 2, args
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, err
    assert not out.exists()


def test_every_marker_in_the_data_is_fitted(tmp_path):
    """Markers inside the body (this test needs the bodies' markers: ``CylinderBody.markers()``
    returning the description's [[markers]])."""
    robot = load_robot(tension_toml(tmp_path / "r.toml", [("mid", [0.1, 0.0, 0.01]), ("near", [0.15, 0.01, 0.0])]))
    u = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.5, 0.5], [0.5, 0.0, 2.5], [1.0, 1.0, 1.0]])
    y = emulate(robot, u, 1.3, softness=1.2)
    assert y.shape == (5, 9)
    res = calibrate(robot, u, y, **MESH, noise_m=1e-5, groups="softness,density")
    assert res.residuals_m.shape == (5, 9) and res.markers == ("tip", "mid", "near")
    assert abs(res.values["density"] / 1.3 - 1) < 0.03
