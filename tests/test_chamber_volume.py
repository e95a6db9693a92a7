"""Volume-controlled chambers (``"chambers_volume"``): a syringe's fluid volume in a cavity.

The fluid's energy K/(2 V0) (V - V0 - u)^2 and its derivatives against central differences
(``helpers.fd_jacobian``) and torch autograd; the rank-one fluid stiffness that the statics
add by Woodbury against a dense solve; a volume and the pressure it produces giving the same
equilibrium both ways; dq/du (exact and reused) against differences of solves; how many
Newton steps water's stiffness costs; the inputs refused. The hollow bodies are meshed with
gmsh as in ``test_chamber_pressure``.
"""

import dataclasses

import numpy as np
import pytest
import torch
from helpers import fd_jacobian
from test_chamber_pressure import E_PA, NU, HollowBody, gmsh_mesh, hollow_box

from lab.errors import InputError
from lab.fem import (
    ACTUATORS,
    ArmFEM,
    NeoHookeanMaterial,
    VolumeChamberActuator,
    cavity_surfaces,
    sensitivities,
    solve_static,
)
from lab.fem.solve.steps import newton_step

WATER = 2.2e9  # Pa


@pytest.fixture(scope="module")
def robot(three_cable):
    """The three-cable description without gravity (its body is replaced, its cables unused)."""
    return dataclasses.replace(three_cable, gravity_m_s2=np.zeros(3))


@pytest.fixture(scope="module")
def box():
    return hollow_box()


@pytest.fixture(scope="module")
def two_boxes():
    """A 6 x 4 x 4 cm block with two 1.5 x 2 x 1.5 cm box cavities side by side."""

    def build(occ):
        outer = occ.addBox(0, 0, 0, 0.06, 0.04, 0.04)
        holes = [occ.addBox(x, 0.01, 0.01, 0.015, 0.02, 0.015) for x in (0.01, 0.035)]
        occ.cut([(3, outer)], [(3, h) for h in holes])

    return gmsh_mesh(build, 0.01)


def chamber_fem(robot, mesh, kind="chambers_volume", **options):
    clamped = mesh.X_W[:, 0] < mesh.X_W[:, 0].min() + 1e-9
    surfaces = cavity_surfaces(mesh)
    if kind == "chambers_volume":
        options = {"volume_max_m3": 1e-6} | options
    else:
        options = {"pressure_max_pa": 2e4} | options
    names = [f"c{i}" for i in range(len(surfaces))]
    return ArmFEM(
        robot,
        body=HollowBody(mesh, clamped),
        material=NeoHookeanMaterial(E_PA, NU),
        actuators=[(kind, {"surfaces": surfaces, "names": names} | options)],
    )


def full_hessian(fem, q, u):
    """fem.hessian (follower term only) + the condensation's rank term A (K/V0) A^T, dense."""
    g, cond = fem.gradient(q, u, with_condensation=True)
    K = cond.law(cond.stretch)[2]
    return fem.hessian(q, u).toarray() + (cond.A * K) @ cond.A.T


def test_registered_and_inputs_checked(robot, box):
    fem = chamber_fem(robot, box)
    act = fem.actuators[0]
    assert ACTUATORS["chambers_volume"] is VolumeChamberActuator and isinstance(act, VolumeChamberActuator)
    assert fem.input_names == ("volume_m3[c0]",) and act.input_unit == "m^3" and act.condenses
    assert act.V0_m3[0] == pytest.approx(6e-6, rel=1e-12) and act.stiffness[0] == pytest.approx(WATER / 6e-6)
    assert act.energy(box.X_W, np.zeros(1)) == 0.0 and act.pressures(box.X_W, [6e-9])[0] == pytest.approx(WATER / 1e3)
    with pytest.raises(InputError, match=r"chamber 'c0' would collapse: volume_m3\[c0\] = -6.1e-06 m\^3"):
        fem.check_input([-6.1e-6])
    with pytest.raises(InputError, match="'c0' would collapse"):
        fem.check_input(-act.V0_m3)
    with pytest.raises(InputError, match=r"outside their range: volume_m3\[c0\] = 2e-06 m\^3, range \[0.0, 1e-06\]"):
        fem.check_input([2e-6])
    with pytest.raises(InputError, match=r"volume_m3\[c0\] = -1e-07 m\^3"):
        fem.check_input([-1e-7])
    with pytest.raises(InputError, match=r"volume_m3\[c0\] = nan"):
        fem.check_input([np.nan])
    # Withdrawing fluid: allowed down to volume_min_m3, never to a collapse.
    withdraw = chamber_fem(robot, box, volume_min_m3=-1e-5)
    assert withdraw.check_input([-5e-6])[0] == -5e-6
    with pytest.raises(InputError, match="'c0' would collapse"):
        withdraw.check_input([-7e-6])
    (cavity,) = cavity_surfaces(box)
    build = VolumeChamberActuator.build
    for bad, match in (
        ({"volume_max_m3": 0.0}, "volume_max_m3"),
        ({"volume_max_m3": 1e-6, "volume_min_m3": 2e-6}, "volume_min_m3"),
        ({"volume_max_m3": 1e-6, "fluid_bulk_modulus_pa": -1.0}, "fluid_bulk_modulus_pa"),
        ({"volume_max_m3": 1e-6, "names": ["a", "b"]}, "2 names for 1 chambers"),
    ):
        with pytest.raises(InputError, match=match):
            build(robot, fem.body, fem.coordinates, surfaces=[cavity], **bad)
    # One condensing actuator per model: two volume actuators (or volume chambers beside
    # angle-controlled cables) are refused; one actuator takes several chambers instead.
    clamped = box.X_W[:, 0] < 1e-9
    spec = ("chambers_volume", {"surfaces": [cavity], "volume_max_m3": 1e-6})
    with pytest.raises(InputError, match="at most one actuator may ask the statics for a condensation"):
        ArmFEM(robot, body=HollowBody(box, clamped), material=NeoHookeanMaterial(E_PA, NU), actuators=[spec, spec])


@pytest.mark.parametrize("bulk_pa", [2e6, WATER])
def test_derivatives_match_differences_and_autograd(robot, box, bulk_pa):
    """With a soft fluid (2 MPa: the follower and rank terms of comparable size) and water."""
    fem = chamber_fem(robot, box, fluid_bulk_modulus_pa=bulk_pa)
    act = fem.actuators[0]
    rng = np.random.default_rng(5)
    q = fem.rest_q() + 2e-4 * rng.standard_normal(fem.n_free)
    x, u = fem.to_nodes(q), np.array([2e-7])
    V0, tri = act.V0_m3[0], act.surfaces[0]

    def energy_t(x_t):
        a, b, c = x_t[tri[:, 0]], x_t[tri[:, 1]], x_t[tri[:, 2]]
        V = -(a * torch.linalg.cross(b, c)).sum() / 6
        return bulk_pa / (2 * V0) * (V - V0 - u[0]) ** 2

    x_t = torch.tensor(x, requires_grad=True)
    E_t = energy_t(x_t)
    (g_t,) = torch.autograd.grad(E_t, x_t)
    assert float(E_t.detach()) == pytest.approx(act.energy(x, u), rel=1e-12)
    g_act, cond = act.gradient(x, u)
    assert np.allclose(g_act, g_t.numpy().ravel()[fem.free_dofs], rtol=0, atol=1e-12 * np.abs(g_act).max())
    assert not cond.in_hessian and cond.gain == -1.0 and cond.inputs == slice(0, 1)
    assert np.allclose(cond.A[:, 0] * act.law(cond.stretch)[1][0], g_act, rtol=0, atol=1e-12 * np.abs(g_act).max())
    # The full Hessian over the cavity's nodes: follower blocks + rank term against autograd.
    nodes = np.unique(tri)
    dofs = (3 * nodes[:, None] + np.arange(3)).ravel()

    def energy_of_cavity_nodes(y):
        full = torch.tensor(x).clone()
        full[nodes] = y.reshape(-1, 3)
        return energy_t(full)

    H_t = torch.autograd.functional.hessian(energy_of_cavity_nodes, torch.tensor(x[nodes].ravel())).numpy()
    u_slack = act.volumes(x) - act.V0_m3  # the fluid at zero pressure: no follower term
    H_act = full_hessian(fem, q, u) - fem.hessian(q, u_slack).toarray()
    free = fem.coordinates.dof_to_free[dofs]
    keep = free >= 0
    H_sub = H_act[np.ix_(free[keep], free[keep])]
    assert np.allclose(H_sub, H_t[np.ix_(keep, keep)], rtol=0, atol=1e-10 * np.abs(H_sub).max())
    # Central differences: the model's energy, gradient, full Hessian and mixed derivative.
    g = fem.gradient(q, u)
    g_fd = fd_jacobian(lambda z: fem.energy(z, u), q, 1e-7)
    assert np.abs(g - g_fd).max() < 1e-8 * np.abs(g).max()  # measured 3.6e-10
    H = full_hessian(fem, q, u)
    H_fd = fd_jacobian(lambda z: fem.gradient(z, u), q, 1e-7)
    assert np.abs(H - H_fd).max() < 1e-8 * np.abs(H).max()  # measured 3.6e-10
    # The follower part alone (what fem.hessian assembles) against differences with the
    # pressure held: the fluid's rank term taken out of the differenced gradient.
    p = act.pressures(x, u)
    H_f_fd = fd_jacobian(lambda z: act.geometry.gradient(fem.to_nodes(z), p)[0], q, 1e-7)
    H_f = fem.hessian(q, u).toarray() - fem.hessian(q, u_slack).toarray()
    assert np.abs(H_f - H_f_fd).max() < 1e-8 * np.abs(H_f).max()  # measured 7.6e-11
    v = rng.standard_normal(fem.n_free)
    assert np.allclose(fem.hessian_operator(q, u)(v), H @ v, rtol=0, atol=1e-10 * np.abs(H @ v).max())
    M = fem.mixed_derivative(q, u)
    assert np.allclose(M[:, 0], -act.stiffness[0] * act.volume_gradients(x)[:, 0], rtol=1e-15, atol=0)
    assert np.abs(M - fd_jacobian(lambda w: fem.gradient(q, w), u, 1e-9)).max() < 1e-10 * np.abs(M).max()


def test_the_condensed_step_is_newton_s_step_of_the_full_hessian(robot, two_boxes):
    """Two chambers (k = 2): the condensed step on the follower-only factorisation is the
    Newton step of H + A K A^T, and Factorised.solve its inverse."""
    fem = chamber_fem(robot, two_boxes)
    rng = np.random.default_rng(1)
    q = fem.rest_q() + 1e-5 * rng.standard_normal(fem.n_free)
    act = fem.actuators[0]
    u = act.volumes(fem.to_nodes(q)) - act.V0_m3 + [3e-12, 1.5e-12]  # about 1.5 and 0.7 kPa
    g, cond = fem.gradient(q, u, with_condensation=True)
    H = full_hessian(fem, q, u)
    d, fac = newton_step(fem.hessian(q, u), g, cond)
    exact = -np.linalg.solve(H, g)
    assert np.abs(d - exact).max() < 1e-8 * np.abs(exact).max()
    assert np.array_equal(fac.K, np.zeros(2)) and np.array_equal(fac.rank_K, cond.law(cond.stretch)[2])
    R = rng.standard_normal((fem.n_free, 3))
    assert np.abs(fac.solve(R) - np.linalg.solve(H, R)).max() < 1e-8 * np.abs(np.linalg.solve(H, R)).max()


def test_a_volume_and_the_pressure_it_makes_give_one_equilibrium(robot, box):
    """Both solves to tol_step_m = 1e-9 m: the error Newton leaves after such a step is far
    below it (measured agreement 2e-13 m, on displacements of 3.5e-4 m). At the default 1e-7
    the volume solve leaves ~1.5e-8 m: its pressure, K/V0 times the volume error, amplifies
    what the last step leaves (docs/fem.md)."""
    vol, pres = chamber_fem(robot, box), chamber_fem(robot, box, kind="chambers_pressure")
    act = vol.actuators[0]
    u = np.array([3e-7])  # 5 % of the cavity
    s_v = solve_static(vol, u, tol_step_m=1e-9)
    p = act.pressures(vol.to_nodes(s_v.q), u)
    assert 2e3 < p[0] < 3e3
    s_p = solve_static(pres, p, tol_step_m=1e-9)
    assert np.abs(s_v.q - s_p.q).max() < 1e-10 and np.abs(s_v.q - vol.rest_q()).max() > 3e-4
    # Converse: a pressure solve; the volume to inject is the cavity's growth plus what
    # the fluid is compressed by at that pressure, p V0 / K.
    p2 = np.array([1.5e3])
    s_p2 = solve_static(pres, p2, tol_step_m=1e-9)
    x = pres.to_nodes(s_p2.q)
    u2 = act.volumes(x) - act.V0_m3 + p2 * act.V0_m3 / WATER
    s_v2 = solve_static(vol, u2, tol_step_m=1e-9)
    assert np.abs(s_v2.q - s_p2.q).max() < 1e-10
    assert act.pressures(vol.to_nodes(s_v2.q), u2)[0] == pytest.approx(p2[0], rel=1e-6)


def test_water_costs_few_newton_steps(robot, box):
    """Measured at the default tolerance, rest start: 3 steps and 2 factorisations for
    3e-7 m^3 (the pressure solve of that equilibrium: 4 and 1), 5 and 3 for 6e-7 m^3 (10 %
    of the cavity; pressure: 5 and 1). Without the multiplier estimate (the Hessian's
    follower term at the penalty's own pressure, MPa away from the equilibrium) the same
    solves took 10-12 steps and 14-15 factorisations with projected steps, or failed."""
    vol, pres = chamber_fem(robot, box), chamber_fem(robot, box, kind="chambers_pressure")
    act = vol.actuators[0]
    for u in (3e-7, 6e-7):
        s_v = solve_static(vol, [u])
        s_p = solve_static(pres, act.pressures(vol.to_nodes(s_v.q), [u]))
        assert s_v.converged and s_v.projected_steps == 0
        assert s_v.iterations <= 6 and s_v.factorizations <= 4
        assert s_v.iterations <= s_p.iterations + 2


def test_sensitivities_match_differences_of_solves(robot, two_boxes):
    """Two chambers: dq/du exact (Woodbury on a fresh factorisation; measured 9e-9 of the
    largest entry off the differences of solves) and reused (the last iterate's
    factorisation: 3e-4; refined along both inputs: 4e-7)."""
    fem = chamber_fem(robot, two_boxes)
    u = np.array([2e-7, 1e-7])
    sol = solve_static(fem, u, sensitivity=True, tol_step_m=1e-9)
    dq_fd = fd_jacobian(lambda w: solve_static(fem, w, sol.q, check_command=False, tol_step_m=1e-12).q, u, 1e-9)
    scale = np.abs(dq_fd).max()
    assert np.abs(sol.dq_du - dq_fd).max() < 1e-6 * scale
    assert np.array_equal(sensitivities(fem, sol.q, u)[0], sol.dq_du)
    du = np.array([[1.0, 0.0], [0.0, 1.0]])
    reused = solve_static(fem, u, sensitivity="reuse", refine_du=du)
    assert np.abs(reused.dq_du - dq_fd).max() < 1e-5 * scale
    unrefined = solve_static(fem, u, sensitivity="reuse")
    assert np.abs(unrefined.dq_du - dq_fd).max() < 3e-3 * scale
