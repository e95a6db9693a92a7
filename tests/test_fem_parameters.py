"""The parametrised FEM (lab.fem.solve.parameters): theta -> FEM, and dx/dtheta against finite
differences, block by block, on a coarse mesh; the nominal and the as-built FEM reproduced."""

import dataclasses

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.asbuilt.arm import as_built_fem, load_defects
from lab.fem.model import ArmFEM
from lab.fem.solve.parameter_layout import ParameterError, ParameterLayout
from lab.fem.solve.parameters import ParametrisedFEM
from lab.fem.solve.statics import sensitivities, solve_static

MESH = dict(n_rings=1, n_axial=6)
U = np.array([1.5, 0.8, 0.3])


@pytest.fixture(scope="module")
def defects(three_cable):
    """The shipped defects with eyelet shifts scaled to fit the 1-ring mesh, plus axial shifts."""
    d = load_defects(None, three_cable)
    axial = [-0.8e-3, -0.3e-3, -0.5e-3]
    cables = tuple(dataclasses.replace(c, via_shift_m=0.4 * c.via_shift_m + [a, 0, 0]) for c, a in zip(d.cables, axial))
    return dataclasses.replace(d, cables=cables)


def theta_of(pf, d):
    return pf.layout.pack(
        d.softness, d.gradient * d.gradient_direction_W[1:], [c.via_shift_m for c in d.cables], d.slack_m
    )


def test_layout_names_pack_unpack(three_cable):
    lay = ParameterLayout(tuple(c.name for c in three_cable.cables))
    assert lay.size == 12 and lay.names[:4] == ["log_softness", "gradient_y", "gradient_z", "via_shift_y_m[top]"]
    assert lay.names[-1] == "slack_m[lower-right]" and lay.units[0] == "1" and lay.units[-1] == "m"
    shift = np.array([[0, 1e-3, -2e-3], [0, 0, 5e-4], [0, -1e-4, 0]])
    th = lay.pack(0.8, (0.1, -0.2), shift, [0, 1e-3, 2e-3])
    v = lay.unpack(th)
    assert np.isclose(v["softness"], 0.8) and np.allclose(v["via_shift_m"], shift)
    assert np.allclose(v["gradient"], [0.1, -0.2]) and np.allclose(v["slack_m"], [0, 1e-3, 2e-3])
    with pytest.raises(ParameterError, match="axes='xyz'"):
        lay.pack(via_shift_m=shift + [1e-3, 0, 0])
    with pytest.raises(ParameterError, match="expected 12 parameters"):
        lay.unpack(np.zeros(5))
    assert ParameterLayout(lay.cable_names, "xyz").size == 15


def test_nominal_theta_is_exactly_the_nominal_fem(three_cable, coarse_fem):
    pf = ParametrisedFEM(three_cable, **MESH)
    assert np.array_equal(pf.nominal, np.zeros(12))
    a = solve_static(coarse_fem, U)
    b = pf.solve(pf.nominal, U)
    assert np.array_equal(a.p_tip_W, b.p_tip_W) and np.array_equal(a.q, b.q)


def test_theta_from_defects_is_the_as_built_fem(three_cable, defects):
    pf = ParametrisedFEM(three_cable, **MESH, axes="xyz")
    th = theta_of(pf, defects)
    ref = as_built_fem(three_cable, defects, **MESH)
    for u in (np.zeros(3), U, np.array([0.2, 2.4, 1.0])):
        a, b = solve_static(ref, u), pf.solve(th, u)
        assert np.abs(a.p_tip_W - b.p_tip_W).max() < 1e-12
    # With the in-plane layout only the axial shifts are dropped: they are refused, not lost.
    with pytest.raises(ParameterError):
        theta_of(ParametrisedFEM(three_cable, **MESH), defects)


def test_description_at_theta_gives_the_same_fem(three_cable, defects):
    """The description's optional stiffness_gradient and slack_m fields carry theta: a plain
    ArmFEM of the description at theta is the FEM at theta."""
    pf = ParametrisedFEM(three_cable, **MESH, axes="xyz")
    th = theta_of(pf, defects)
    fem = ArmFEM(pf.description(th), **MESH)
    assert np.allclose(fem.elastic.mu, pf.fem(th).elastic.mu, rtol=1e-14, atol=0)
    assert np.abs(solve_static(fem, U).p_tip_W - pf.solve(th, U).p_tip_W).max() < 1e-12


@pytest.mark.parametrize("axes", ["yz", "xyz"])
def test_parameter_sensitivities_match_finite_differences(three_cable, defects, axes):
    pf = ParametrisedFEM(three_cable, **MESH, axes=axes)
    lay = pf.layout
    shift = np.array([c.via_shift_m for c in defects.cables])
    if axes == "yz":
        shift[:, 0] = 0.0
    # A generic point: every cable taut, eyelets off the faces of their tets.
    th, u = lay.pack(0.8, (0.2, -0.3), shift, [0.0, 1e-3, 5e-4]), np.array([1.5, 1.2, 1.0])
    sol = pf.solve(th, u, tol_step_m=1e-10)
    fem = pf.fem(th)
    assert np.all(fem.cable_tensions(fem.to_nodes(sol.q), u) > 0.1)
    dq_du, dq_dth, J_u, J_th = pf.sensitivities(th, sol.q, u)
    assert np.allclose(dq_du, sensitivities(fem, sol.q, u)[0], rtol=0, atol=1e-10 * np.abs(dq_du).max())

    def tip(t):
        return pf.solve(t, u, sol.q, tol_step_m=1e-10).p_tip_W

    blocks = {"material": (slice(0, 3), 1e-6), "shift": (slice(3, lay.slack.start), 1e-7), "slack": (lay.slack, 1e-7)}
    for name, (sl, h) in blocks.items():
        idx = np.arange(lay.size)[sl]

        def f(v, idx=idx):
            t = th.copy()
            t[idx] = v
            return tip(t)

        J_fd = fd_jacobian(f, th[idx], h)
        err = np.abs(J_fd - J_th[:, idx]).max() / np.abs(J_fd).max()
        assert err < 1e-6, f"{name}: relative error {err:.2e}"
        assert np.all(np.abs(J_fd).max(axis=0) > 1e-3)  # every parameter moves the tip
    assert np.allclose(J_th, fem.tip_matrix() @ dq_dth)


def test_parameters_outside_the_model_are_refused(three_cable):
    pf = ParametrisedFEM(three_cable, **MESH)
    th = pf.nominal.copy()
    th[1:3] = [0.8, 0.7]
    with pytest.raises(ParameterError, match="gradient"):
        pf.fem(th)
    th = pf.nominal.copy()
    th[pf.layout.shift(0)] = [0.0, 0.006]  # the top cable's eyelets 21 mm from the axis: outside
    with pytest.raises(ParameterError, match="outside"):
        pf.fem(th)
    with pytest.raises(ParameterError, match="finite"):
        pf.fem(np.full(12, np.nan))
    pf = ParametrisedFEM(three_cable, **MESH, axes="xyz")
    th = pf.nominal.copy()
    th[pf.layout.shift(0).start] = 1e-3  # the top cable's last eyelet beyond the tip face
    with pytest.raises(ParameterError, match="length"):
        pf.fem(th)
