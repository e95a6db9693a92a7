import dataclasses

import numpy as np
import pytest

from lab.fem import ArmFEM
from lab.statics import StaticSolveError, sensitivities, solve_static


def test_sensitivity_matches_finite_differences(default_fem):
    fem = default_fem
    u = np.array([2.0, 1.0, 0.5])
    sol = solve_static(fem, u, sensitivity=True)
    h = 1e-5
    J_fd = np.column_stack([(solve_static(fem, u + h * e, sol.q).p_tip_W - solve_static(fem, u - h * e, sol.q).p_tip_W)
                            / (2 * h) for e in np.eye(3)])
    assert np.abs(sol.J_tip_u - J_fd).max() < 1e-6 * np.abs(J_fd).max()
    dq_fd = (solve_static(fem, u + h * np.eye(3)[0], sol.q).q - solve_static(fem, u - h * np.eye(3)[0], sol.q).q) / (2 * h)
    assert np.abs(sol.dq_du[:, 0] - dq_fd).max() < 1e-6 * np.abs(dq_fd).max()
    # A projected (PSD) Hessian is *not* good enough for sensitivities:
    from lab.linsolve import factorize
    dq_proj = -factorize(fem.hessian(sol.q, u, project=True)).solve(fem.mixed_derivative(sol.q, u))
    J_proj = fem.tip_matrix() @ dq_proj
    assert np.abs(J_proj - J_fd).max() > 100 * np.abs(sol.J_tip_u - J_fd).max()


def test_warm_start_gives_the_cold_start_equilibrium(default_fem):
    u = np.array([0.5, 2.5, 1.0])
    cold = solve_static(default_fem, u)
    near = solve_static(default_fem, u - [0, 0.5, 0], sensitivity=True)
    warm = solve_static(default_fem, u, near.q + near.dq_du @ [0, 0.5, 0])
    assert warm.iterations < cold.iterations
    assert np.allclose(warm.p_tip_W, cold.p_tip_W, atol=1e-8)


def test_pulling_a_cable_bends_towards_it(default_fem, three_cable):
    rest = solve_static(default_fem, [0, 0, 0])
    assert rest.p_tip_W[2] < -0.005  # sags under gravity
    for i, cable in enumerate(three_cable.cables):
        u = np.zeros(3)
        u[i] = three_cable.u_max_rad
        tip = solve_static(default_fem, u, rest.q).p_tip_W
        direction = cable.via_points_m[0, 1:] / np.linalg.norm(cable.via_points_m[0, 1:])
        moved = tip[1:] - rest.p_tip_W[1:]
        assert moved @ direction > 0.05  # centimetres towards the pulled side
        assert tip[0] < rest.p_tip_W[0] - 0.01  # and the tip swings back


def test_symmetry(three_cable):
    """No gravity and equal contractions: the tip stays on the axis. With gravity, the
    arm is mirror-symmetric about the x-z plane (cables 1 and 2 are mirror images)."""
    fem0 = ArmFEM(dataclasses.replace(three_cable, gravity_m_s2=np.zeros(3)))
    tip = solve_static(fem0, [2.0, 2.0, 2.0]).p_tip_W
    single = solve_static(fem0, [2.0, 0.0, 0.0]).p_tip_W
    bend = np.linalg.norm(single[1:])
    assert np.linalg.norm(tip[1:]) < 0.01 * bend
    assert tip[0] < three_cable.length_m - 0.005  # the arm shortens
    fem = ArmFEM(three_cable)
    a = solve_static(fem, [0.5, 2.5, 1.0]).p_tip_W
    b = solve_static(fem, [0.5, 1.0, 2.5]).p_tip_W
    # The prism split of the mesh is not itself mirror-symmetric: ~2 % on the default mesh.
    assert a[1] == pytest.approx(-b[1], abs=0.05 * abs(a[1]))
    assert a[[0, 2]] == pytest.approx(b[[0, 2]], abs=0.05 * abs(a[1]))


def test_cold_solve_of_a_small_command_converges(default_fem):
    """Regression: the final, tiny Newton steps used to be rejected by the line search
    (energy rounding), stalling at max_iter for u = [0.25, 0, 0] on the default mesh."""
    sol = solve_static(default_fem, [0.25, 0.0, 0.0])
    assert sol.converged and sol.iterations < 20


def test_failures_are_reported(default_fem):
    with pytest.raises(StaticSolveError, match="failed"):
        solve_static(default_fem, [3.0, 0, 0], max_iter=1)
    sol = solve_static(default_fem, [3.0, 0, 0], max_iter=1, raise_on_failure=False)
    assert not sol.converged and sol.status == "max_iter"
    q_bad = default_fem.rest_q()
    q_bad[:] = 0.0  # all nodes on top of each other: every element inverted
    with pytest.raises(ValueError, match="inverted"):
        solve_static(default_fem, [0, 0, 0], q_bad)
    with pytest.raises(ValueError, match="finite"):
        solve_static(default_fem, [np.nan, 0, 0])


@pytest.mark.slow
def test_small_load_cantilever_matches_beam_theory(three_cable):
    """Gravity sag of the cable-free body against Timoshenko beam theory. Linear tets are
    too stiff in bending (locking); the error must shrink with refinement (to ~10 % at 2,500 nodes)."""
    robot = dataclasses.replace(three_cable, cable_stiffness_n_m=1e-12, gravity_m_s2=np.array([0, 0, -0.0981]))
    E, nu, rho, L, R = robot.youngs_modulus_pa, robot.poisson_ratio, robot.density_kg_m3, robot.length_m, robot.radius_m
    ratios = []
    for n_rings, n_axial in [(2, 20), (3, 30), (4, 40)]:
        n = 6 * n_rings  # the section is a regular n-gon
        A = 0.5 * n * R**2 * np.sin(2 * np.pi / n)
        I = n * R**4 * np.sin(2 * np.pi / n) * (2 + np.cos(2 * np.pi / n)) / 24
        w = rho * 0.0981 * A
        kappa = 6 * (1 + nu) / (7 + 6 * nu)
        beam = w * L**4 / (8 * E * I) + w * L**2 / (2 * kappa * E / (2 * (1 + nu)) * A)
        sag = -solve_static(ArmFEM(robot, n_rings=n_rings, n_axial=n_axial), [0, 0, 0]).p_tip_W[2]
        ratios.append(sag / beam)
    assert ratios[0] < ratios[1] < ratios[2] < 1.02
    assert ratios[2] > 0.85


@pytest.mark.slow
def test_tip_converges_under_mesh_refinement(three_cable):
    u = np.array([0.0, 1.5, 3.0])
    tips = [solve_static(ArmFEM(three_cable, n_rings=n, n_axial=10 * n), u).p_tip_W for n in (1, 2, 3, 4)]
    steps = [np.linalg.norm(b - a) for a, b in zip(tips, tips[1:])]
    assert steps[0] > steps[1] > steps[2]
    assert steps[2] < 3e-3


def test_sensitivities_function_matches_solution(default_fem):
    sol = solve_static(default_fem, [1.0, 0.0, 2.0], sensitivity="reuse")
    dq, J = sensitivities(default_fem, sol.q, sol.u_motor)
    # reuse = the factorisation one (tiny) Newton step before the equilibrium
    assert np.allclose(sol.J_tip_u, J, rtol=1e-3, atol=1e-5)  # a predictor, not Soft IK
