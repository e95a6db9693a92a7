"""The hyperfoam law (lab.fem.materials.hyperfoam): derivatives against central differences and torch
autograd (also at and around repeated principal stretches), its small-strain limit, a
closed-form uniaxial test, and the arm's statics with it against the neo-Hookean law."""

import dataclasses

import numpy as np
import pytest
import torch
from helpers import fd_jacobian
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from lab.errors import InputError
from lab.fem import ArmFEM, solve_static
from lab.fem.bodies.mesh import cylinder_mesh
from lab.fem.materials.elements import InvertedElementError
from lab.fem.materials.hyperfoam import (
    REPEATED_LOG_GAP,
    Hyperfoam,
    HyperfoamMaterial,
    hyperfoam_law,
    hyperfoam_matching,
)
from lab.fem.materials.neo_hookean import lame

MU = 1.5e4
R1, R2 = Rotation.from_rotvec([0.3, -0.5, 0.8]).as_matrix(), Rotation.from_rotvec([-0.7, 0.2, 0.4]).as_matrix()
_rng = np.random.default_rng(5)
#: Stretch gaps (relative) just below and just above the switch to the repeated-value limit.
BELOW, ABOVE = 0.4 * REPEATED_LOG_GAP, 0.6 * REPEATED_LOG_GAP
STATES = {
    "rest": np.eye(3),
    "near rest": np.eye(3) + 1e-3 * _rng.standard_normal((3, 3)),
    "far": np.eye(3) + 0.3 * _rng.standard_normal((3, 3)),
    "uniaxial (double)": R1 @ np.diag([1.5, 0.8, 0.8]) @ R2,
    "double, gap below the limit": R1 @ np.diag([1.5, 0.8, 0.8 * (1 + BELOW)]) @ R2,
    "double, gap above the limit": R1 @ np.diag([1.5, 0.8, 0.8 * (1 + ABOVE)]) @ R2,
    "dilation (triple)": 1.2 * R1,
    "compressed": R1 @ np.diag([0.4, 0.9, 1.1]) @ R2,
}


def _law(F, alpha, beta, order):
    return hyperfoam_law(np.asarray(F).reshape(1, 3, 3), MU, alpha, beta, order)


@pytest.mark.parametrize("alpha, beta", [(2.0, 0.4), (8.5, 0.0), (20.0, 0.25), (-4.0, 0.3)])
@pytest.mark.parametrize("state", list(STATES))
def test_stress_and_tangent_match_finite_differences(state, alpha, beta):
    F = STATES[state]
    _, P, A = _law(F, alpha, beta, 2)
    P_fd = fd_jacobian(lambda f: _law(f, alpha, beta, 0)[0][0], F.ravel(), 1e-6).reshape(3, 3)
    A_fd = fd_jacobian(lambda f: _law(f, alpha, beta, 1)[1].ravel(), F.ravel(), 1e-6).reshape(3, 3, 3, 3)
    assert np.abs(P[0] - P_fd).max() < 1e-7 * max(MU, np.abs(P).max())
    assert np.abs(A[0] - A_fd).max() < 1e-7 * np.abs(A).max()


def test_repeated_stretch_limit_is_continuous():
    """Both sides of REPEATED_LOG_GAP give the same tangent to the size of the gap."""
    below = _law(STATES["double, gap below the limit"], 20.0, 0.25, 2)[2]
    above = _law(STATES["double, gap above the limit"], 20.0, 0.25, 2)[2]
    at = _law(STATES["uniaxial (double)"], 20.0, 0.25, 2)[2]
    scale = np.abs(at).max()
    assert 0 < np.abs(above - below).max() < 1e-5 * scale
    assert np.abs(below - at).max() < 1e-5 * scale


def _torch_density(F, alpha, beta):
    c = torch.linalg.eigvalsh(F.T @ F)
    J = torch.det(F)
    return 2 * MU / alpha**2 * ((c ** (alpha / 2)).sum() - 3 + (J ** (-alpha * beta) - 1) / beta)


@pytest.mark.parametrize("state", ["far", "compressed"])
def test_stress_and_tangent_match_torch_autograd(state):
    """An independent implementation (torch's eigenvalues, the energy as written); at
    distinct stretches, where autograd through eigvalsh is defined."""
    alpha, beta = 8.5, 0.4
    F = torch.tensor(STATES[state], dtype=torch.float64)
    P_t = torch.autograd.functional.jacobian(lambda f: _torch_density(f, alpha, beta), F).numpy()
    A_t = torch.autograd.functional.hessian(lambda f: _torch_density(f, alpha, beta), F).numpy()
    W, P, A = _law(STATES[state], alpha, beta, 2)
    assert W[0] == pytest.approx(float(_torch_density(F, alpha, beta)), rel=1e-12)
    assert np.allclose(P[0], P_t, rtol=1e-10, atol=1e-10 * MU)
    assert np.allclose(A[0], A_t, rtol=1e-9, atol=1e-10 * np.abs(A_t).max())


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45])
@pytest.mark.parametrize("alpha", [2.0, 8.5, 20.0])
def test_small_strain_tangent_is_linear_elasticity(alpha, nu):
    E = 4e4
    mu, beta = hyperfoam_matching(E, nu, alpha)
    _, lam = lame(E, nu)
    assert 2 * mu * (1 / 3 + beta) - 2 * mu / 3 == pytest.approx(lam, rel=1e-12, abs=1e-9)  # K0 - 2/3 mu
    d = np.eye(3)
    C = lam * np.einsum("ij,kl->ijkl", d, d) + mu * (np.einsum("ik,jl->ijkl", d, d) + np.einsum("il,jk->ijkl", d, d))
    _, P0, A = hyperfoam_law(np.eye(3)[None], mu, alpha, beta)
    assert np.abs(P0).max() == 0 and np.abs(A[0] - C).max() < 1e-12 * E
    # The law itself at F = I + eps H: linear stress C : eps H, error O(eps^2).
    H = STATES["far"] - np.eye(3)
    for eps in (1e-3, 1e-4):
        P = hyperfoam_law((np.eye(3) + eps * H)[None], mu, alpha, beta, 1)[1][0]
        assert np.abs(P - np.einsum("ijkl,kl->ij", C, eps * H)).max() < 30 * alpha**2 * eps**2 * E


@pytest.mark.parametrize("alpha", [8.5, -4.0])
@pytest.mark.parametrize("nu", [0.0, 0.25])
@pytest.mark.parametrize("stretch", [0.5, 0.8, 1.3, 2.0])
def test_uniaxial_stress_closed_form(stretch, nu, alpha):
    """Free lateral stretch: P_22 = 0 solves to lam_L = stretch^-nu (1 for nu = 0: no Poisson
    effect), and P_11 = (2 mu / alpha) (stretch^(alpha - 1) - stretch^(-alpha nu - 1))."""
    beta = hyperfoam_matching(2 * MU * (1 + nu), nu, alpha)[1]

    def lateral_stress(lam_L):
        return _law(np.diag([stretch, lam_L, lam_L]), alpha, beta, 1)[1][0, 1, 1]

    lam_L = brentq(lateral_stress, 0.3, 3.0, xtol=1e-15, rtol=1e-15)
    assert lam_L == pytest.approx(stretch**-nu, rel=1e-12)
    closed = 2 * MU / alpha * (stretch ** (alpha - 1) - stretch ** (-alpha * nu - 1))
    # Rotated both ways, so that nothing is diagonal: P(R1 F R2) = R1 P(F) R2.
    P = R1.T @ _law(R1 @ np.diag([stretch, lam_L, lam_L]) @ R2, alpha, beta, 1)[1][0] @ R2.T
    assert P[0, 0] == pytest.approx(closed, rel=1e-11)
    assert np.abs(P - np.diag([closed, 0, 0])).max() < 1e-11 * abs(closed)


def test_homogeneous_stretch_of_a_mesh():
    """An affine stretch of a cylinder: energy V W(F), no force inside, end-face force P_11 A."""
    mesh = cylinder_mesh(0.05, 0.02, 2, 3)
    alpha, nu, stretch = 8.5, 0.25, 1.3
    mu, beta = hyperfoam_matching(2 * MU * (1 + nu), nu, alpha)
    foam = Hyperfoam.from_mesh(mesh, mu, alpha, beta)
    F = np.diag([stretch, stretch**-nu, stretch**-nu])
    x = mesh.X_W @ F.T
    W = _law(F, alpha, beta, 0)[0][0]
    assert foam.energy(x) == pytest.approx(foam.V.sum() * W, rel=1e-12)
    g = foam.nodal_gradient(x)
    X = mesh.X_W
    inner = (X[:, 0] > 1e-9) & (X[:, 0] < 0.05 - 1e-9) & (np.hypot(X[:, 1], X[:, 2]) < 0.02 - 1e-6)
    P11 = 2 * mu / alpha * (stretch ** (alpha - 1) - stretch ** (-alpha * nu - 1))
    assert inner.any() and np.abs(g[inner]).max() < 1e-12 * P11 * 1e-4
    end = X[:, 0] > 0.05 - 1e-9
    assert g[end, 0].sum() == pytest.approx(P11 * foam.V.sum() / 0.05, rel=1e-12)


def test_rest_and_rigid_motion_are_stress_free_and_inversion_is_infinite():
    mesh = cylinder_mesh(0.2, 0.02, 1, 2)
    foam = Hyperfoam.from_mesh(mesh, MU, 8.5, 0.4)
    x = mesh.X_W @ R1.T + [0.1, -0.2, 0.3]
    assert abs(foam.energy(mesh.X_W)) < 1e-15 and abs(foam.energy(x)) < 1e-14
    assert np.abs(foam.gradient(x)).max() < 1e-12
    mirror = mesh.X_W * [-1, 1, 1]
    assert foam.energy(mirror) == np.inf and foam.energy_and_gradient(mirror) == (np.inf, None)
    with pytest.raises(InvertedElementError):
        foam.hessian(mirror)


@pytest.fixture(scope="module")
def coarse_foam(three_cable):
    mu, beta = hyperfoam_matching(three_cable.youngs_modulus_pa, three_cable.poisson_ratio, 8.5)
    return ArmFEM(three_cable, n_rings=1, n_axial=6, material=HyperfoamMaterial(mu, 8.5, beta))


def test_arm_energy_derivatives_match_finite_differences(coarse_foam):
    fem = coarse_foam
    q = fem.rest_q() + 2e-3 * np.random.default_rng(1).standard_normal(fem.n_free)
    u = np.array([2.0, 0.7, 0.1])
    g = fem.gradient(q, u)
    assert np.abs(g - fd_jacobian(lambda z: fem.energy(z, u), q, 1e-7)).max() < 1e-6 * np.abs(g).max()
    H = fem.hessian(q, u).toarray()
    assert np.abs(H - fd_jacobian(lambda z: fem.gradient(z, u), q, 1e-7)).max() < 1e-6 * np.abs(H).max()
    assert np.abs(H - H.T).max() < 1e-12 * np.abs(H).max()
    apply = fem.hessian_operator(q, u)
    v = np.random.default_rng(2).standard_normal(fem.n_free)
    assert np.abs(apply(v) - H @ v).max() < 1e-12 * np.abs(H @ v).max()
    E, g2, _ = fem.energy(q, u, with_gradient=True)
    assert E == fem.energy(q, u) and np.array_equal(g, g2)
    x = fem.to_nodes(q)
    summed = np.zeros_like(x)
    np.add.at(summed, fem.mesh.tets, fem.elastic.gradient(x))
    assert np.allclose(fem.elastic.nodal_gradient(x), summed, rtol=0, atol=1e-13 * np.abs(summed).max())
    # Element blocks projected to PSD where the solver needs a descent direction.
    H_el = fem.elastic.hessian(x)
    assert np.linalg.eigvalsh(H_el).min() < 0 < np.linalg.eigvalsh(fem.hessian(q, u, project=True).toarray()).min()


def test_per_tet_modulus_scales_each_tets_forces(three_cable):
    """softness/gradient scale mu per tet: each element force is linear in its own mu."""
    mesh = cylinder_mesh(0.2, 0.02, 1, 4)
    scale = 1 + 0.5 * mesh.X_W[mesh.tets].mean(axis=1)[:, 1] / 0.02
    x = mesh.X_W + 1e-3 * np.random.default_rng(3).standard_normal(mesh.X_W.shape)
    one, graded = (Hyperfoam.from_mesh(mesh, MU * s, 8.5, 0.4) for s in (1.0, scale))
    for law in ("gradient", "hessian"):
        expected = scale[:, None, None] * getattr(one, law)(x)
        assert np.abs(getattr(graded, law)(x) - expected).max() < 1e-13 * np.abs(expected).max()


def test_arm_statics_against_neo_hookean(three_cable):
    """Matched small-strain stiffness: a small command moves the tip as the neo-Hookean arm
    does (without gravity's prestrain; measured 0.06 %), a large one differs (measured 7 %)."""
    robot = dataclasses.replace(three_cable, gravity_m_s2=np.zeros(3))
    mu, beta = hyperfoam_matching(robot.youngs_modulus_pa, robot.poisson_ratio, 20.0)
    arms = [ArmFEM(robot, n_rings=2, n_axial=10, material=m) for m in (None, HyperfoamMaterial(mu, 20.0, beta))]
    rest = arms[0].tip(arms[0].X_W)

    def rel_difference(u):
        nh, foam = (solve_static(f, u).p_tip_W - rest for f in arms)
        return np.linalg.norm(foam - nh) / np.linalg.norm(nh)

    assert rel_difference([0.02, 0, 0]) < 2e-3
    assert rel_difference([0, 3.0, 3.0]) > 0.03


def test_bad_parameters_are_refused(three_cable):
    bad = [{"mu_pa": -1.0}, {"mu_pa": [1.0, np.inf]}, {"alpha": 0.0}, {"alpha": np.inf}, {"alpha": np.nan}]
    for kwargs in [*bad, {"beta": -0.1}]:
        with pytest.raises(InputError, match="hyperfoam"):
            HyperfoamMaterial(**({"mu_pa": 1e4, "alpha": 8.0, "beta": 0.3} | kwargs))
    for E, nu in ((4e4, 0.5), (4e4, -0.1), (0.0, 0.3)):
        with pytest.raises(InputError, match="hyperfoam matching"):
            hyperfoam_matching(E, nu, 8.0)
    with pytest.raises(InputError, match="not both"):
        ArmFEM(three_cable, n_rings=1, n_axial=2, youngs_modulus_pa=4e4, material=HyperfoamMaterial(1e4, 8.0, 0.3))
    with pytest.raises(InputError, match="tetrahedra"):
        ArmFEM(three_cable, n_rings=1, n_axial=2, material=HyperfoamMaterial(np.full(5, 1e4), 8.0, 0.3))
    assert HyperfoamMaterial(1e4, 8.0, 0.75).poisson_ratio == pytest.approx(0.3)
