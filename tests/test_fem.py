"""Every derivative of the energy against central finite differences and torch autograd."""

import numpy as np
import pytest
import torch
from helpers import fd_derivative, fd_jacobian

from lab.fem.actuators.cable_routes import spring
from lab.fem.bodies.mesh import cylinder_mesh
from lab.fem.materials.neo_hookean import NeoHookean, project_psd


@pytest.fixture
def state(coarse_fem):
    rng = np.random.default_rng(1)
    q = coarse_fem.rest_q() + 2e-3 * rng.standard_normal(coarse_fem.n_free)
    return coarse_fem, q, np.array([2.0, 0.7, 0.1])


def test_total_gradient_matches_finite_differences(state):
    fem, q, u = state
    g_fd = fd_jacobian(lambda z: fem.energy(z, u), q, 1e-7)
    g = fem.gradient(q, u)
    assert np.abs(g - g_fd).max() < 1e-6 * np.abs(g).max()


def test_total_hessian_matches_finite_differences(state):
    fem, q, u = state
    H = fem.hessian(q, u).toarray()
    H_fd = fd_jacobian(lambda z: fem.gradient(z, u), q, 1e-7)
    assert np.abs(H - H_fd).max() < 1e-6 * np.abs(H).max()
    assert np.abs(H - H.T).max() < 1e-12 * np.abs(H).max()


def test_mixed_derivative_matches_finite_differences(state):
    fem, q, u = state
    B = fem.mixed_derivative(q, u)
    B_fd = fd_jacobian(lambda v: fem.gradient(q, v), u, 1e-6)
    assert np.abs(B - B_fd).max() < 1e-6 * np.abs(B).max()
    assert np.abs(B).max() > 0  # the cables are taut in this state


def _torch_psi(F, mu, lam):
    J = torch.det(F)
    return 0.5 * mu * ((F * F).sum() - 3) - mu * torch.log(J) + 0.5 * lam * torch.log(J) ** 2


def test_neo_hookean_element_against_torch_autograd():
    mesh = cylinder_mesh(0.2, 0.02, 1, 1)
    nh = NeoHookean.from_mesh(mesh, 4e4, 0.3)
    rng = np.random.default_rng(2)
    x = mesh.X_W + 3e-3 * rng.standard_normal(mesh.X_W.shape)
    g, H = nh.gradient(x), nh.hessian(x)
    for m in range(3):
        xe = torch.tensor(x[mesh.tets[m]], dtype=torch.float64, requires_grad=True)
        G = torch.tensor(nh.G[m])

        def energy(xe_flat, G=G, m=m):  # bound now: called at once, inside this iteration
            F = xe_flat.reshape(4, 3).T @ G
            return nh.V[m] * _torch_psi(F, nh.mu[m], nh.lam[m])

        g_t = torch.autograd.functional.jacobian(energy, xe.reshape(-1)).numpy()
        H_t = torch.autograd.functional.hessian(energy, xe.reshape(-1)).numpy()
        assert np.allclose(g[m].ravel(), g_t, rtol=1e-10, atol=1e-14)
        assert np.allclose(H[m], H_t, rtol=1e-9, atol=1e-12 * np.abs(H_t).max())


def test_rest_state_and_rigid_motion_are_stress_free():
    mesh = cylinder_mesh(0.2, 0.02, 2, 4)
    nh = NeoHookean.from_mesh(mesh, 4e4, 0.3)
    assert nh.energy(mesh.X_W) == pytest.approx(0, abs=1e-15)
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    x = mesh.X_W @ R.T + [0.1, -0.2, 0.3]
    assert nh.energy(x) == pytest.approx(0, abs=1e-13)
    assert np.abs(nh.gradient(x)).max() < 1e-10
    assert nh.energy(mesh.X_W * [-1, 1, 1]) == np.inf  # the mirror image: every tet inverted


def test_psd_projection():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((5, 12, 12))
    A = A + A.transpose(0, 2, 1)
    P = project_psd(A)
    assert np.linalg.eigvalsh(P).min() > -1e-12
    B = A @ A.transpose(0, 2, 1)  # already PSD: unchanged
    assert np.allclose(project_psd(B), B)


def test_spring_is_one_sided_and_smooth():
    k, eps = 5e3, 2e-4
    d = np.linspace(-1e-3, 2e-3, 3001)
    E, T, S = spring(d, k, eps)
    assert np.all(E[d <= 0] == 0) and np.all(T[d <= 0] == 0)
    beyond = d > eps
    assert np.allclose(T[beyond], k * (d[beyond] - eps / 2))  # a linear spring shifted by eps/2
    h = 1e-9
    assert np.allclose(fd_derivative(lambda z: spring(z, k, eps)[0], d, h), T, atol=1e-6)
    assert np.allclose(fd_derivative(lambda z: spring(z, k, eps)[1], d, h), S, atol=1e-2)


def test_cable_length_derivatives(coarse_fem):
    cable = coarse_fem.cables[1]
    x = coarse_fem.X_W + 1e-3 * np.random.default_rng(4).standard_normal(coarse_fem.X_W.shape)
    L, dL_dp, d2L = cable.length_derivatives(x)
    W = cable.embedding_matrix()
    xe = x[cable.nodes].reshape(-1)

    def length(xe_flat):
        x2 = x.copy()
        for (k, j), v in zip(np.ndindex(*cable.nodes.shape), xe_flat.reshape(-1, 3)):
            x2[cable.nodes[k, j]] = v
        return cable.length(x2)

    assert L == pytest.approx(length(xe))
    # Nodes can repeat between via points, so compare in via-point coordinates.
    p = (W @ xe).reshape(-1, 3)
    anchor = cable.anchor_W

    def length_p(p_flat):
        pts = np.vstack([anchor, p_flat.reshape(-1, 3)])
        return np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()

    g_fd = fd_jacobian(length_p, p.ravel(), 1e-7)
    assert np.allclose(dL_dp.ravel(), g_fd, atol=1e-7)
    H_fd = fd_jacobian(lambda z: fd_jacobian(length_p, z, 1e-7), p.ravel(), 1e-5)
    assert np.allclose(d2L, H_fd, atol=1e-3 * np.abs(d2L).max())


def test_energy_with_gradient_and_cable_jacobian(state):
    fem, q, u = state
    E, g, cond = fem.energy(q, u, with_gradient=True)
    assert E == fem.energy(q, u)
    g2, cond2 = fem.gradient(q, u, with_condensation=True)
    d, A = cond.stretch, cond.A
    assert np.array_equal(g, g2) and np.array_equal(d, cond2.stretch) and np.array_equal(A, cond2.A)
    assert cond.inputs == slice(0, 3) and cond.gain == fem.robot.spool_radius_m
    x = fem.to_nodes(q)
    assert np.allclose(d, fem.cable_lengths(x) - fem.cable_targets(u), rtol=0, atol=1e-15)

    def lengths(z):
        return fem.cable_lengths(fem.to_nodes(z))

    A_fd = fd_jacobian(lengths, q, 1e-7).T
    assert np.abs(A - A_fd).max() < 1e-6
    # The nodal gradient (B^T of the stresses) is the element gradients summed at the nodes.
    g_el = fem.elastic.gradient(x)
    summed = np.zeros_like(x)
    np.add.at(summed, fem.mesh.tets, g_el)
    assert np.allclose(fem.elastic.nodal_gradient(x), summed, rtol=0, atol=1e-13 * np.abs(summed).max())
    q_bad = fem.rest_q() * 0.0
    assert fem.energy(q_bad, u, with_gradient=True) == (np.inf, None, None)


def test_hessian_operator_matches_the_assembled_hessian(state):
    fem, q, u = state
    H = fem.hessian(q, u)
    apply = fem.hessian_operator(q, u)
    V = np.random.default_rng(7).standard_normal((fem.n_free, 3))
    for v in V.T:
        assert np.abs(apply(v) - H @ v).max() < 1e-12 * np.abs(H @ v).max()
    # Also with a slack cable (no tension: no turning term) and with gravity only.
    u0 = np.zeros(3)
    assert np.abs(fem.hessian_operator(q, u0)(V[:, 0]) - fem.hessian(q, u0) @ V[:, 0]).max() < 1e-9
