"""Tendons pulled by tension (``"tendons_tension"``): the energy sum_c T_c (L_c - L0_c), its
derivatives against central differences (``helpers.fd_jacobian``) and torch autograd, the
sensitivity dq/dT against differences of solves, and the equilibrium under tensions T equal
to the one under the motor angles whose cables carry T.
"""

import numpy as np
import pytest
import torch
from helpers import fd_jacobian

from lab.errors import InputError
from lab.fem import ACTUATORS, ArmFEM, sensitivities, solve_static
from lab.fem.actuators.tension import TensionTendonActuator

MESH = dict(n_rings=1, n_axial=6)


@pytest.fixture(scope="module")
def tendons(three_cable):
    """The coarse three-cable arm, its cables pulled by tension."""
    return ArmFEM(three_cable, **MESH, actuators=["tendons_tension"])


def test_registered_with_inputs_in_newtons(tendons, three_cable):
    act = tendons.actuators[0]
    assert ACTUATORS["tendons_tension"] is TensionTendonActuator and isinstance(act, TensionTendonActuator)
    assert act.input_unit == "N" and tendons.n_inputs == len(three_cable.cables)
    assert tendons.input_names == tuple(f"tension_n[{c.name}]" for c in three_cable.cables)
    k, r, u_max = three_cable.cable_stiffness_n_m, three_cable.spool_radius_m, three_cable.u_max_rad
    assert np.array_equal(act.input_bounds()[1], np.full(3, k * r * u_max))
    assert tendons.input_states(tendons.rest_q(), [0.0, 2.0, 0.0]) == (False, True, False)
    # At rest the routes have their rest lengths: zero energy whatever the tensions.
    assert act.energy(tendons.X_W, np.array([1.0, 2.0, 3.0])) == pytest.approx(0.0, abs=1e-15)


def test_inputs_outside_the_bounds_are_refused(three_cable):
    fem = ArmFEM(three_cable, **MESH, actuators=[("tendons_tension", {"tension_max_n": 5.0})])
    assert np.array_equal(fem.check_input([0.0, 5.0, 1.0]), [0.0, 5.0, 1.0])
    for bad in ([0.0, 5.5, 0.0], [-0.1, 0.0, 0.0], [np.nan, 0.0, 0.0]):
        with pytest.raises(InputError, match=r"tendons_tension inputs .* N outside their range"):
            fem.check_input(bad)
    with pytest.raises(InputError, match="tendons_tension inputs"):
        solve_static(fem, [6.0, 0.0, 0.0])
    with pytest.raises(InputError, match="tension_max_n"):
        ArmFEM(three_cable, **MESH, actuators=[("tendons_tension", {"tension_max_n": 0.0})])


def test_derivatives_match_differences_and_autograd(tendons):
    fem, act = tendons, tendons.actuators[0]
    rng = np.random.default_rng(5)
    q = fem.rest_q() + 2e-3 * rng.standard_normal(fem.n_free)
    u = np.array([1.5, 0.4, 2.0])
    x = fem.to_nodes(q)
    # The tendons' own energy and gradient against autograd of sum_c T_c (L_c - L0_c).
    x_t = torch.tensor(x, requires_grad=True)
    e = torch.zeros((), dtype=torch.float64)
    for route, t in zip(act.routes, u):
        p = (torch.tensor(route.weights)[:, :, None] * x_t[route.nodes]).sum(dim=1)
        pts = torch.cat([torch.tensor(route.anchor_W)[None], p])
        e = e + t * (torch.linalg.norm(pts[1:] - pts[:-1], dim=1).sum() - route.L0_m)
    e.backward()
    assert float(e.detach()) == pytest.approx(act.energy(x, u), rel=1e-12)
    g_torch = x_t.grad.numpy().ravel()[fem.free_dofs]
    g_act, condensation = act.gradient(x, u)
    assert condensation is None
    assert np.allclose(g_act, g_torch, rtol=0, atol=1e-14 * np.abs(g_torch).max())
    e_a, g_a, c_a = act.energy_and_gradient(x, u)
    assert e_a == act.energy(x, u) and np.array_equal(g_a, g_act) and c_a is None
    # The model with the tendons: gradient, Hessian, Hessian products and mixed derivative.
    g = fem.gradient(q, u)
    assert np.abs(g - fd_jacobian(lambda z: fem.energy(z, u), q, 1e-7)).max() < 1e-6 * np.abs(g).max()
    H = fem.hessian(q, u).toarray()
    assert np.abs(H - fd_jacobian(lambda z: fem.gradient(z, u), q, 1e-7)).max() < 1e-6 * np.abs(H).max()
    v = rng.standard_normal(fem.n_free)
    assert np.allclose(fem.hessian_operator(q, u)(v), H @ v, rtol=0, atol=1e-9 * np.abs(H @ v).max())
    # The tendons' own Hessian part: the change of their gradient alone.
    H_act = H - fem.hessian(q, np.zeros(3)).toarray()
    H_fd = fd_jacobian(lambda z: act.gradient(fem.to_nodes(z), u)[0], q, 1e-7)
    assert np.abs(H_act - H_fd).max() < 1e-6 * np.abs(H_act).max()
    M = fem.mixed_derivative(q, u)
    assert np.abs(M - fd_jacobian(lambda w: fem.gradient(q, w), u, 1e-3)).max() < 1e-9 * np.abs(M).max()
    assert np.allclose(M, fd_jacobian(lambda z: act.lengths(fem.to_nodes(z)), q, 1e-7).T, rtol=0, atol=1e-8)


def test_sensitivity_matches_central_differences(tendons):
    u = np.array([1.5, 0.4, 0.8])
    sol = solve_static(tendons, u, sensitivity=True)

    def q_of(w):
        return solve_static(tendons, w, sol.q, check_command=False, tol_step_m=1e-10).q

    dq_fd = fd_jacobian(q_of, u, 1e-3)
    assert np.abs(sol.dq_du - dq_fd).max() < 1e-5 * np.abs(sol.dq_du).max()
    assert np.array_equal(sensitivities(tendons, sol.q, u)[0], sol.dq_du)


def test_zero_tension_is_the_gravity_only_equilibrium(three_cable, tendons):
    """Zero tensions add exact zeros to the energy, gradient and Hessian; the Hessian's
    pattern holds the tendons' (zero) blocks, so the factorisations round differently and
    the equilibria agree to the solver's accuracy (measured 1e-12 m), not bit for bit."""
    none = ArmFEM(three_cable, **MESH, actuators=[])
    q = tendons.rest_q() + 1e-3 * np.sin(np.arange(tendons.n_free))
    assert tendons.energy(q, np.zeros(3)) == none.energy(q, np.zeros(0))
    assert np.array_equal(tendons.gradient(q, np.zeros(3)), none.gradient(q, np.zeros(0)))
    H, H_none = tendons.hessian(q, np.zeros(3)), none.hessian(q, np.zeros(0))
    assert np.array_equal(H.toarray(), H_none.toarray()) and H.nnz > H_none.nnz
    bare = solve_static(none, np.zeros(0))  # a model without inputs takes an empty u
    zero = solve_static(tendons, np.zeros(3))
    assert np.abs(zero.q - bare.q).max() < 1e-9
    assert np.linalg.norm(zero.p_tip_W - bare.p_tip_W) < 1e-9


@pytest.mark.parametrize("u_motor_rad", [[2.0, 0.0, 0.0], [1.5, 1.2, 0.0], [0.0, 1.5, 2.5], [1.0, 1.0, 1.0]])
def test_tension_equals_the_angle_that_produces_it(coarse_fem, tendons, u_motor_rad):
    """The equilibrium under the tensions T the angle-controlled cables carry at u equals the
    one under u. At the angle model's equilibrium the two models' forces agree to rounding
    (both are elastic + gravity + A T; measured: bit for bit). The equilibria then differ by the solves' errors:
    each stops at a Newton step below tol_step_m = 1e-7 m, and the angle solve's remaining
    error enters T times the cable stiffness (5000 N/m), which the tendons, having no spring,
    resist less (most when all three pull). Measured tip distances: 4e-12, 5e-10, 4e-11 and
    1.3e-8 m for these four commands; the tolerance is the solver's step tolerance, 1e-7 m.
    Only taut cables (stretch beyond the smoothing width) are used, where the spring's
    tension is the linear law's."""
    u = np.array(u_motor_rad)
    angle = solve_static(coarse_fem, u)
    x = coarse_fem.to_nodes(angle.q)
    stretch = coarse_fem.cable_lengths(x) - coarse_fem.cable_targets(u)
    tension = coarse_fem.cable_tensions(x, u)
    pulled = tension > 0
    assert np.all(stretch[pulled] > coarse_fem.robot.slack_smoothing_m) and np.all(tension[~pulled] == 0)
    g_angle, g_tension = coarse_fem.gradient(angle.q, u), tendons.gradient(angle.q, tension)
    assert np.abs(g_tension - g_angle).max() <= 1e-15  # N (measured: 0)
    pulled_by_tension = solve_static(tendons, tension)
    assert np.linalg.norm(pulled_by_tension.p_tip_W - angle.p_tip_W) < 1e-7
    assert np.abs(pulled_by_tension.q - angle.q).max() < 1e-7
    assert tendons.input_states(pulled_by_tension.q, tension) == coarse_fem.input_states(angle.q, u)


def test_angle_cables_and_tension_tendons_at_once(three_cable, coarse_fem):
    """Both on one body: the tendons' tension adds to the cables' pull on the same routes."""
    both = ArmFEM(three_cable, **MESH, actuators=["cables", ("tendons_tension", {"tension_max_n": 5.0})])
    assert both.n_inputs == 6 and both.input_names[3:] == tuple(f"tension_n[{c.name}]" for c in three_cable.cables)
    u3 = np.array([1.5, 0.3, 0.0])
    q = coarse_fem.rest_q() + 1e-3 * np.sin(np.arange(coarse_fem.n_free))
    assert both.energy(q, np.r_[u3, 0, 0, 0]) == coarse_fem.energy(q, u3)
    assert np.array_equal(both.gradient(q, np.r_[u3, 0, 0, 0]), coarse_fem.gradient(q, u3))
    u = np.r_[u3, 0.0, 0.0, 1.0]
    sol = solve_static(both, u, sensitivity=True)
    assert sol.converged and np.abs(both.gradient(sol.q, u)).max() < 1e-8
    assert sol.dq_du.shape == (both.n_free, 6)
    M = both.mixed_derivative(sol.q, u)
    assert np.abs(M - fd_jacobian(lambda w: both.gradient(sol.q, w), u, 1e-4)).max() < 1e-5 * np.abs(M).max()
