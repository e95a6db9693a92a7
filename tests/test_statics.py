import dataclasses

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.fem.model import ArmFEM
from lab.fem.solve.statics import StaticSolveError, sensitivities, solve_static


def test_sensitivity_matches_finite_differences(default_fem):
    fem = default_fem
    u = np.array([2.0, 1.0, 0.5])
    sol = solve_static(fem, u, sensitivity=True)
    h = 1e-5
    J_fd = fd_jacobian(lambda v: solve_static(fem, v, sol.q).p_tip_W, u, h)
    assert np.abs(sol.J_tip_u - J_fd).max() < 1e-6 * np.abs(J_fd).max()
    dq_fd = fd_jacobian(lambda v: solve_static(fem, np.array([v[0], *u[1:]]), sol.q).q, u[:1], h)[:, 0]
    assert np.abs(sol.dq_du[:, 0] - dq_fd).max() < 1e-6 * np.abs(dq_fd).max()
    # A projected (PSD) Hessian is *not* good enough for sensitivities:
    from lab.fem.solve.linsolve import factorize

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


@pytest.fixture(scope="module")
def equilibrium(default_fem):
    """A tight equilibrium with the top cable inside its smoothed zone, and its dq/du."""
    u = np.array([0.0, 1.0, 2.0])
    ref = solve_static(default_fem, u, tol_step_m=1e-12)
    return u, ref, sensitivities(default_fem, ref.q, u)[0]


def test_condensed_step_resolves_the_smoothed_cable_spring(default_fem, equilibrium):
    from lab.fem.solve.linsolve import factorize
    from lab.fem.solve.steps import newton_step

    fem, (u, ref, D) = default_fem, equilibrium
    stretch = fem.cable_lengths(fem.to_nodes(ref.q)) - fem.cable_targets(u)
    assert 0 < stretch[0] < fem.robot.slack_smoothing_m  # stiffness k d / eps: varies fast
    q0 = ref.q + 1e-3 * D[:, 0]  # ~40 um off, mostly in cable 0's stretch
    g, cond = fem.gradient(q0, u, with_condensation=True)
    H = fem.hessian(q0, u)
    dq, fac = newton_step(H, g, cond)
    plain = -factorize(H).solve(g)
    err, err_plain = np.abs(q0 + dq - ref.q).max(), np.abs(q0 + plain - ref.q).max()
    assert err < 0.4 * err_plain
    assert fac is not None and np.allclose(fac.C, fac.A.T @ fac.S)


def test_a_condensation_evaluates_its_law_once(default_fem, equilibrium):
    # The cables hand their own evaluation of the law to the condensation; a condensation
    # built without one evaluates it when first asked, and once only.
    from lab.fem.actuators.base import Condensation

    fem, (u, ref, _) = default_fem, equilibrium
    for cond in (fem.gradient(ref.q, u, with_condensation=True)[1], fem.energy(ref.q, u, with_gradient=True)[2]):
        for given, fresh in zip(cond.at_stretch(), cond.law(cond.stretch)):
            assert np.array_equal(given, fresh)
    calls = []
    law = lambda d: calls.append(1) or cond.law(d)  # noqa: E731
    lazy = Condensation(cond.A, cond.stretch, law, cond.scale, cond.inputs, cond.gain)
    assert lazy.at_stretch() is lazy.at_stretch() and len(calls) == 1


def test_close_start_converges_with_one_factorisation_and_chord_steps(default_fem, equilibrium):
    fem, (u, ref, D) = default_fem, equilibrium
    for amp in (3e-4, 1e-3):  # 10 and 30 um from the equilibrium
        sol = solve_static(fem, u, ref.q + amp * D[:, 1])
        assert sol.factorizations == 1 and sol.iterations > 1
        assert np.abs(sol.q - ref.q).max() < 1e-9  # far below tol_step_m = 1e-7


def test_reused_sensitivity_is_refined_along_refine_du(default_fem, equilibrium):
    fem, (u, ref, D) = default_fem, equilibrium
    q0 = ref.q + 3e-3 * D[:, 1]  # the factorisation is ~1e-4 m off
    plain = solve_static(fem, u, q0, sensitivity="reuse")
    refined = solve_static(fem, u, q0, sensitivity="reuse", refine_du=[[0.0, 0.5, 0.0]])
    assert plain.factorizations == refined.factorizations == 1

    def rel(sol, j):
        return np.abs(sol.dq_du[:, j] - D[:, j]).max() / np.abs(D[:, j]).max()

    assert rel(refined, 1) < 1e-3 and rel(refined, 1) < 0.02 * rel(plain, 1)
    assert np.allclose(refined.dq_du[:, [0, 2]], plain.dq_du[:, [0, 2]])  # only along du
    assert np.allclose(refined.J_tip_u, fem.tip_matrix() @ refined.dq_du)


def test_indefinite_start_is_reported_or_shifted(default_fem):
    fem = default_fem
    q0 = fem.to_free(fem.mesh.X_W * [0.9, 1, 1])  # squashed 10 %: the Hessian is indefinite
    stop = solve_static(fem, [0, 0, 0], q0, stop_if_indefinite=True, raise_on_failure=False)
    assert stop.status == "indefinite" and not stop.converged and stop.factorizations == 1
    sol = solve_static(fem, [0, 0, 0], q0)
    assert sol.converged and sol.projected_steps == 0  # diagonal shifts were enough
    assert np.abs(sol.p_tip_W - solve_static(fem, [0, 0, 0]).p_tip_W).max() < 1e-9


def test_shifted_step():
    import scipy.sparse as sp

    from lab.fem.solve.steps import SHIFTS, shifted_step

    n = 50
    rng = np.random.default_rng(5)
    off = sp.random(n, n, density=0.05, random_state=6) * 10.0
    H = (sp.diags(np.full(n, 1000.0)) + off + off.T).tocsr()
    H.setdiag(H.diagonal() - np.r_[1000.5, np.zeros(n - 1)])  # one eigenvalue near -0.5
    g = rng.standard_normal(n)
    s = SHIFTS[0] * np.median(H.diagonal())
    expected = -np.linalg.solve(H.toarray() + s * np.eye(n), g)
    d, used = shifted_step(H.copy(), g)
    assert used == 1 and np.allclose(d, expected) and g @ d < 0
    H.setdiag(H.diagonal() - np.r_[1000.0, np.zeros(n - 1)])  # far more negative than any shift
    assert shifted_step(H, g) == (None, len(SHIFTS))


def test_pardiso_solves_without_refinement_when_no_pivot_was_perturbed(default_fem, equilibrium):
    from lab.fem.solve.linsolve import _available, factorize

    if "pardiso" not in _available():
        pytest.skip("pypardiso not installed")
    u, ref, _ = equilibrium
    H = default_fem.hessian(ref.q, u)
    lu = factorize(H, "pardiso")
    b = np.random.default_rng(0).standard_normal(H.shape[0])
    x = lu.solve(b)
    assert lu.n_perturbed == 0 and int(lu._solver.get_iparm(7)) == 0  # no refinement steps run
    assert np.linalg.norm(H @ x - b) < 1e-14 * abs(H).max() * np.linalg.norm(x)


def test_the_line_search_assembles_the_next_newton_step_s_hessian(three_cable, default_fem, monkeypatch):
    """With FUSED_TRIALS, on a law whose evaluation is costly (the hyperfoam's), a
    full-length trial far from the equilibrium evaluates energy, gradient and Hessian in
    one pass, and the next step factorises that Hessian: the same solve step for step,
    with fewer separate assemblies. The neo-Hookean arm assembles apart."""
    import lab.fem.solve.statics as statics
    from lab.fem import use_assembly
    from lab.fem.materials import HyperfoamMaterial

    foam = ArmFEM(three_cable, n_rings=2, n_axial=8, material=HyperfoamMaterial(1.4e4, 13.96, 0.75))
    u = np.array([2.5, 0.0, 1.0])
    calls, fused_calls = [], []
    hessian, energy = ArmFEM.hessian, ArmFEM.energy
    monkeypatch.setattr(ArmFEM, "hessian", lambda self, *a, **k: calls.append(1) or hessian(self, *a, **k))
    monkeypatch.setattr(
        ArmFEM, "energy", lambda self, *a, **k: fused_calls.append(k.get("with_hessian")) or energy(self, *a, **k)
    )
    out = {}
    with use_assembly("compiled"):
        assert foam.trial_hessians_pay and not default_fem.trial_hessians_pay
        for fused in (False, True):
            monkeypatch.setattr(statics, "FUSED_TRIALS", fused)
            calls.clear()
            sol = solve_static(foam, u)
            out[fused] = sol, len(calls)
        calls.clear()
        neo = solve_static(default_fem, u)
        assert len(calls) == neo.factorizations
    (plain, n_plain), (fused, n_fused) = out.values()
    assert np.array_equal(fused.q, plain.q)
    assert (fused.iterations, fused.factorizations) == (plain.iterations, plain.factorizations)
    assert n_plain == plain.factorizations and 0 < n_fused < n_plain - 2
    used = fused.factorizations - n_fused
    assert sum(bool(f) for f in fused_calls) > used  # and some trials' Hessians were thrown away
