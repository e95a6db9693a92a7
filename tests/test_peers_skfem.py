"""lab.peers.skfem_arm: the arm's body in scikit-fem against our FEM (issue 17), coarse mesh.

Both FEMs discretise the same energy (neo-Hookean on P1 tets, whose gradients are constant per
tet, so scikit-fem's quadrature is exact; gravity's consistent load equals our lumped one), so
their equilibria differ only by the Newton tolerances: ours stops after a step below 1e-7 m
with quadratic convergence, scikit-fem's after one below 1e-10 m, leaving errors far below
1e-9 m (measured 2e-11 m here, 1e-9 m on the default mesh). A wrong law, load or clamp moves
the tip by millimetres. scikit-fem is a pinned dependency (environment.txt): these tests fail,
not skip, without it.
"""

import numpy as np
import pytest
import skfem
from helpers import fd_jacobian

from lab.description import load_robot
from lab.errors import InputError
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.peers.skfem_arm import SkfemArm, lab_loaded_arm, lab_tip_load_gradient, tip_load_node


def test_skfem_is_installed():
    assert skfem.__version__ == "12.0.2"  # the pin of environment.txt


@pytest.fixture(scope="module")
def setup():
    fem = ArmFEM(load_robot("three-cable"), n_rings=2, n_axial=8)
    return fem, SkfemArm(fem)


def test_same_energy_at_a_deformed_state(setup):
    fem, sk = setup
    arm = lab_loaded_arm(fem, 0.0)  # cables slack: our energy is elastic + gravity only
    q = arm.rest_q() + 1e-3 * np.random.default_rng(0).standard_normal(arm.n_free)
    assert sk.energy(arm.to_nodes(q)) == pytest.approx(arm.energy(q, np.zeros(3)), rel=1e-11)
    assert sk.energy(fem.X_W) == pytest.approx(arm.energy(arm.rest_q(), np.zeros(3)), rel=1e-11)
    # A free node pushed 1 m along the axis inverts its tets: infinite energy in both.
    q_bad = q.copy()
    q_bad[0] += 1.0
    assert np.isinf(arm.energy(q_bad, np.zeros(3))) and np.isinf(sk.energy(arm.to_nodes(q_bad)))


@pytest.mark.parametrize("load_n", [0.0, 0.05])
def test_gravity_sag_and_tip_load_match_ours(setup, load_n):
    fem, sk = setup
    arm = lab_loaded_arm(fem, load_n)
    ours = solve_static(arm, np.zeros(3))
    assert np.all(arm.cable_tensions(arm.to_nodes(ours.q), np.zeros(3)) == 0)  # cables really slack
    theirs = sk.solve(load_n)
    sag = np.linalg.norm(ours.p_tip_W - fem.tip(fem.X_W))
    assert sag > 0.01  # 12 mm under gravity, 27 mm with 50 mN: a real deflection
    np.testing.assert_allclose(theirs.x_W, arm.to_nodes(ours.q), rtol=0, atol=1e-9)
    np.testing.assert_allclose(theirs.p_tip_W, ours.p_tip_W, rtol=0, atol=1e-9)


def test_adjoint_tip_load_gradient_matches_fd_and_ours(setup):
    fem, sk = setup
    F0 = 5e-3
    sol = sk.solve(F0)
    g_sk = sk.tip_load_gradient(sol)
    # Central differences of the equilibrium (each solve to 1e-10 m; h = 0.1 mN moves the tip
    # ~30 um, so the rounding error is ~1e-6 relative and the truncation error smaller).
    g_fd = fd_jacobian(lambda F: sk.solve(F[0]).p_tip_W, np.array([F0]), h=1e-4)[:, 0]
    np.testing.assert_allclose(g_sk, g_fd, rtol=0, atol=1e-6 * np.abs(g_fd).max())
    arm = lab_loaded_arm(fem, F0)
    g_ours = lab_tip_load_gradient(arm, solve_static(arm, np.zeros(3)).q)
    np.testing.assert_allclose(g_sk, g_ours, rtol=0, atol=1e-7 * np.abs(g_ours).max())
    assert g_sk[2] < -0.1  # m/N: a downward load lowers the tip (0.29 mm/mN here)
    # Another direction is another gradient (the load really goes where the direction says).
    g_y = sk.tip_load_gradient(sol, (0.0, 1.0, 0.0))
    assert g_y[1] > 0.1 and abs(g_y[2]) < 0.1 * g_y[1]


def test_load_node_and_bad_direction(setup):
    fem, sk = setup
    assert tip_load_node(fem) in fem.tip_nodes
    with pytest.raises(InputError, match="direction"):
        sk.solve(0.01, (0.0, 0.0, 0.0))
    with pytest.raises(InputError, match="direction"):
        lab_loaded_arm(fem, 0.01, (1.0, np.nan, 0.0))
