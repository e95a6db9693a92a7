"""Sensitivities from the static solve's own factorisation (lab.fem.solve.nearby): dx/dtheta
equal to a fresh factorisation's to round-off and to central differences, with no new
factorisation; a factorisation too far from the equilibrium is refused (a fresh one is made)."""

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.fem.solve.linsolve import factorize
from lab.fem.solve.nearby import NEAR_M, nearby_preconditioner, nearby_sensitivities, refined_solve
from lab.fem.solve.parameters import ParametrisedFEM, marker_rows

MESH = dict(n_rings=1, n_axial=6)
U = np.array([1.5, 1.2, 1.0])


@pytest.fixture(scope="module")
def trial(three_cable):
    """A calibration's trial step: the equilibrium at theta moved by dq/dtheta times a small
    step, solved from there (its last Newton step converges: the factorisation is near)."""
    pf = ParametrisedFEM(three_cable, **MESH)
    th = pf.layout.pack(0.8, (0.2, -0.3), np.zeros((3, 3)), [0.0, 1e-3, 5e-4])
    sol = pf.solve(th, U, tol_step_m=1e-10)
    step = 1e-2 * np.array([1.0, 0.5, -0.5] + [1e-3] * 9)
    start = sol.q + pf.sensitivities(th, sol.q, U)[1] @ step
    moved = pf.solve(th + step, U, start, keep_factorisation=True)
    return pf, th + step, moved


def test_reused_factorisation_gives_the_fresh_sensitivities(trial):
    pf, th, sol = trial
    fac, condensation, distance = sol.factorisation
    assert fac is not None and condensation is not None and distance <= NEAR_M  # a taut cable, condensed
    before = pf.n_factorisations
    dq_du, dq_dth, J_u, J_th = pf.sensitivities(th, sol.q, U, factorisation=sol.factorisation)
    assert pf.n_factorisations == before  # no new factorisation
    fresh = pf.sensitivities(th, sol.q, U)
    assert pf.n_factorisations == before + 1
    for got, ref in ((J_u, fresh[2]), (J_th, fresh[3])):
        assert np.abs(got - ref).max() <= 1e-10 * np.abs(ref).max()  # round-off
    for got, ref in ((dq_du, fresh[0]), (dq_dth, fresh[1])):  # the predictors: the preconditioner alone
        assert np.abs(got - ref).max() <= 1e-2 * np.abs(ref).max()


def test_reused_sensitivities_match_central_differences(trial):
    pf, th, sol = trial
    J_th = pf.sensitivities(th, sol.q, U, factorisation=sol.factorisation)[3]

    def tip(t):
        return pf.solve(t, U, sol.q, tol_step_m=1e-10).p_tip_W

    lay = pf.layout
    for sl, h in ((slice(0, 3), 1e-6), (slice(3, lay.size), 1e-7)):  # material; eyelet shifts and slack (m)
        idx = np.arange(lay.size)[sl]

        def f(v, idx=idx):
            t = th.copy()
            t[idx] = v
            return tip(t)

        J_fd = fd_jacobian(f, th[idx], h)
        assert np.abs(J_fd - J_th[:, idx]).max() <= 1e-6 * np.abs(J_fd).max()


def test_a_distant_factorisation_is_refused(trial):
    pf, th, sol = trial
    fac, condensation, _ = sol.factorisation
    fem = pf.fem(th)
    B = np.hstack([fem.mixed_derivative(sol.q, U), pf.force_derivative(th, sol.q, U)])
    S = marker_rows(fem)
    assert nearby_sensitivities(fem, sol.q, U, B, S, fac, condensation, 10 * NEAR_M) is None
    assert nearby_sensitivities(fem, sol.q, U, B, S, None, condensation, 0.0) is None
    before = pf.n_factorisations
    far = pf.sensitivities(th, sol.q, U, factorisation=(fac, condensation, 10 * NEAR_M))
    assert pf.n_factorisations == before + 1  # factorised afresh: exactly the fresh result
    assert all(np.array_equal(a, b) for a, b in zip(far, pf.sensitivities(th, sol.q, U)))


def test_refined_solve_reaches_the_exact_hessians_solution(trial):
    pf, th, sol = trial
    fem = pf.fem(th)
    rest = pf.solve(th, np.zeros(3))  # a preconditioner from far away: still converges, in more iterations
    fac = type("F", (), {"solve": staticmethod(factorize(fem.hessian(rest.q, np.zeros(3))).solve), "A": None})()
    R = np.random.default_rng(0).standard_normal((fem.n_free, 2))
    H = fem.hessian(sol.q, U)
    X, products = refined_solve(lambda V: H @ V, nearby_preconditioner(fac, None), R, R, max_iter=60)
    exact = factorize(fem.hessian(sol.q, U)).solve(R)
    assert X is not None and products > 2
    assert np.abs(R.T @ (X - exact)).max() <= 1e-9 * np.abs(R.T @ exact).max()
