"""The Yeoh law (lab.fem.materials.yeoh): stress and tangent against central differences
(``helpers.fd_jacobian``) and torch autograd, the small-strain limit against the
neo-Hookean law, inverted elements refused, per-tet parameters, the arm's derivatives with
it (PSD projection included) and bad parameters refused."""

import numpy as np
import pytest
import torch
from helpers import fd_jacobian

from lab.errors import InputError
from lab.fem import MATERIALS, ArmFEM, NeoHookean, YeohMaterial, yeoh_matching
from lab.fem.bodies.mesh import cylinder_mesh
from lab.fem.materials.elements import InvertedElementError
from lab.fem.materials.neo_hookean import lame
from lab.fem.materials.yeoh import Yeoh, yeoh_law

C10, C20, C30, KAPPA = 8.4e3, 1.0e3, 50.0, 4e5
_rng = np.random.default_rng(7)
STATES = {
    "rest": np.eye(3),
    "near rest": np.eye(3) + 1e-3 * _rng.standard_normal((3, 3)),
    "far": np.eye(3) + 0.3 * _rng.standard_normal((3, 3)),
    "stretched": np.diag([1.8, 0.75, 0.8]),
    "compressed": np.diag([0.5, 1.2, 1.1]) + 0.1 * _rng.standard_normal((3, 3)),
}


def _law(F, order, c20=C20, c30=C30):
    return yeoh_law(np.asarray(F).reshape(1, 3, 3), C10, c20, c30, KAPPA, order)


def test_registered():
    assert MATERIALS["yeoh"] is YeohMaterial


@pytest.mark.parametrize("state", list(STATES))
def test_stress_and_tangent_match_finite_differences(state):
    F = STATES[state]
    _, P, A = _law(F, 2)
    P_fd = fd_jacobian(lambda f: _law(f, 0)[0][0], F.ravel(), 1e-6).reshape(3, 3)
    A_fd = fd_jacobian(lambda f: _law(f, 1)[1].ravel(), F.ravel(), 1e-6).reshape(3, 3, 3, 3)
    assert np.abs(P[0] - P_fd).max() < 1e-7 * max(KAPPA, np.abs(P).max())
    assert np.abs(A[0] - A_fd).max() < 1e-7 * np.abs(A).max()
    assert np.allclose(A[0].reshape(9, 9), A[0].reshape(9, 9).T, rtol=0, atol=1e-10 * np.abs(A).max())


def _torch_density(F):
    J = torch.det(F)
    x = J ** (-2.0 / 3.0) * (F * F).sum() - 3
    return C10 * x + C20 * x**2 + C30 * x**3 + 0.5 * KAPPA * (J - 1) ** 2


@pytest.mark.parametrize("state", ["far", "stretched", "compressed"])
def test_energy_stress_and_tangent_match_torch_autograd(state):
    """The energy as written, differentiated twice by autograd."""
    F = torch.tensor(STATES[state], dtype=torch.float64)
    P_t = torch.autograd.functional.jacobian(_torch_density, F).numpy()
    A_t = torch.autograd.functional.hessian(_torch_density, F).numpy()
    W, P, A = _law(STATES[state], 2)
    assert W[0] == pytest.approx(float(_torch_density(F)), rel=1e-12)
    assert np.allclose(P[0], P_t, rtol=1e-10, atol=1e-10 * KAPPA)
    assert np.allclose(A[0], A_t, rtol=1e-9, atol=1e-10 * np.abs(A_t).max())


@pytest.mark.parametrize("nu", [0.3, 0.45, 0.49])
def test_small_strain_limit_is_the_neo_hookean_law(nu):
    """E = 2 mu (1 + nu), mu = 2 C10: the same tangent at F = I as linear elasticity (and the
    neo-Hookean law), the same element Hessians at rest, and the same energy to second order."""
    mu, kappa, E = yeoh_matching(C10, nu)
    _, lam = lame(E, nu)
    assert kappa == pytest.approx(lam + 2 * mu / 3, rel=1e-12)
    d = np.eye(3)
    C = lam * np.einsum("ij,kl->ijkl", d, d) + mu * (np.einsum("ik,jl->ijkl", d, d) + np.einsum("il,jk->ijkl", d, d))
    _, P0, A = yeoh_law(np.eye(3)[None], C10, C20, C30, kappa)
    assert np.abs(P0).max() < 1e-9 * mu and np.abs(A[0] - C).max() < 1e-10 * E
    mesh = cylinder_mesh(0.1, 0.02, 1, 3)
    yeoh = YeohMaterial(C10, C20, C30, poisson_ratio=nu).on_mesh(mesh)
    nh = NeoHookean.from_mesh(mesh, E, nu)
    H_y, H_n = yeoh.hessian(mesh.X_W), nh.hessian(mesh.X_W)
    assert np.abs(H_y - H_n).max() < 1e-9 * np.abs(H_n).max()
    dx = _rng.standard_normal(mesh.X_W.shape) * 1e-2
    for eps in (1e-2, 1e-3):
        e_y, e_n = yeoh.energy(mesh.X_W + eps * dx), nh.energy(mesh.X_W + eps * dx)
        assert abs(e_y - e_n) < 20 * eps * e_n  # relative difference O(eps): third order


def test_inverted_elements_are_refused():
    mesh = cylinder_mesh(0.2, 0.02, 1, 2)
    law = YeohMaterial(C10, C20, C30, bulk_modulus_pa=KAPPA).on_mesh(mesh)
    assert abs(law.energy(mesh.X_W)) < 1e-15
    mirror = mesh.X_W * [-1, 1, 1]
    assert law.energy(mirror) == np.inf and law.energy_and_gradient(mirror) == (np.inf, None)
    for method in ("gradient", "nodal_gradient", "hessian", "hessian_product"):
        with pytest.raises(InvertedElementError):
            getattr(law, method)(mirror)


def test_per_tet_parameters_scale_each_tets_forces():
    mesh = cylinder_mesh(0.2, 0.02, 1, 4)
    scale = 1 + 0.5 * mesh.X_W[mesh.tets].mean(axis=1)[:, 1] / 0.02
    x = mesh.X_W + 1e-3 * _rng.standard_normal(mesh.X_W.shape)
    one = YeohMaterial(C10, C20, C30, bulk_modulus_pa=KAPPA).on_mesh(mesh)
    graded = YeohMaterial(C10 * scale, C20 * scale, C30 * scale, bulk_modulus_pa=KAPPA * scale).on_mesh(mesh)
    assert isinstance(graded, Yeoh)
    for law in ("gradient", "hessian"):
        expected = scale[:, None, None] * getattr(one, law)(x)
        assert np.abs(getattr(graded, law)(x) - expected).max() < 1e-12 * np.abs(expected).max()


def test_arm_energy_derivatives_match_finite_differences(three_cable):
    fem = ArmFEM(three_cable, n_rings=1, n_axial=6, material=YeohMaterial(C10, C20, C30, poisson_ratio=0.45))
    q = fem.rest_q() + 2e-3 * np.random.default_rng(1).standard_normal(fem.n_free)
    u = np.array([2.0, 0.7, 0.1])
    g = fem.gradient(q, u)
    assert np.abs(g - fd_jacobian(lambda z: fem.energy(z, u), q, 1e-7)).max() < 1e-6 * np.abs(g).max()
    H = fem.hessian(q, u).toarray()
    assert np.abs(H - fd_jacobian(lambda z: fem.gradient(z, u), q, 1e-7)).max() < 1e-6 * np.abs(H).max()
    assert np.abs(H - H.T).max() < 1e-12 * np.abs(H).max()
    v = np.random.default_rng(2).standard_normal(fem.n_free)
    assert np.abs(fem.hessian_operator(q, u)(v) - H @ v).max() < 1e-12 * np.abs(H @ v).max()
    x = fem.to_nodes(q)
    summed = np.zeros_like(x)
    np.add.at(summed, fem.mesh.tets, fem.elastic.gradient(x))
    assert np.allclose(fem.elastic.nodal_gradient(x), summed, rtol=0, atol=1e-13 * np.abs(summed).max())
    # Strong compression makes element blocks indefinite; the projection makes them PSD.
    x_c = fem.X_W * [0.5, 1.0, 1.0] + 2e-3 * np.random.default_rng(3).standard_normal(fem.X_W.shape)
    assert np.linalg.eigvalsh(fem.elastic.hessian(x_c)).min() < 0
    q_c = x_c.ravel()[fem.free_dofs]
    assert np.linalg.eigvalsh(fem.hessian(q_c, np.zeros(3), project=True).toarray()).min() > -1e-9


def test_bad_parameters_are_refused():
    for kwargs in (
        {"c10_pa": -1.0, "poisson_ratio": 0.45},
        {"c10_pa": np.nan, "poisson_ratio": 0.45},
        {"c10_pa": 1e4, "c20_pa": np.inf, "poisson_ratio": 0.45},
        {"c10_pa": 1e4},
        {"c10_pa": 1e4, "poisson_ratio": 0.45, "bulk_modulus_pa": 1e6},
        {"c10_pa": 1e4, "poisson_ratio": 0.5},
        {"c10_pa": 1e4, "bulk_modulus_pa": -1.0},
    ):
        with pytest.raises(InputError, match="yeoh"):
            YeohMaterial(**kwargs)
    with pytest.raises(InputError, match="tetrahedra"):
        YeohMaterial(np.full(5, 1e4), poisson_ratio=0.45).on_mesh(cylinder_mesh(0.2, 0.02, 1, 2))
