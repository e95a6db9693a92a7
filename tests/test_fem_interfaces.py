"""The FEM's interfaces: a new actuator is one module plus its registration, and the solver
(statics, sensitivities, warm-started walks) uses it without an edit.

The toy actuator here is a constant point force on a body marker, input its magnitude in
newtons along a fixed direction. It is registered from this module only; the model then
holds cables and the point force at once, and every derivative the solver uses is checked
against central differences (``helpers.fd_jacobian``) and torch autograd.
"""

import numpy as np
import pytest
import torch
from helpers import fd_jacobian

from lab.errors import InputError
from lab.fem import (
    ACTUATORS,
    BODIES,
    MATERIALS,
    Actuator,
    ArmFEM,
    CylinderBody,
    HyperfoamMaterial,
    Marker,
    MaterialLaw,
    NeoHookeanMaterial,
    WalkPredictor,
    register_actuator,
    register_body,
    sensitivities,
    solve_static,
)

MESH = dict(n_rings=1, n_axial=6)


@register_actuator("point_force")
class PointForce(Actuator):
    """A force ``u[0]`` N along the unit ``direction`` on one of the body's markers."""

    input_names = ("f_marker_n",)
    input_unit = "N"

    def __init__(self, marker, direction, free, max_n):
        self.marker, self.max_n = marker, max_n
        self.direction = np.asarray(direction, float) / np.linalg.norm(direction)
        self.column = free.point_matrix(marker).T @ self.direction  # d(direction . p)/dq (n_free,)

    @classmethod
    def build(cls, robot, body, free, *, marker="tip", direction=(0.0, 0.0, 1.0), max_n=0.05):
        return cls(body.markers()[marker], direction, free, max_n)

    def input_bounds(self):
        return np.array([-self.max_n]), np.array([self.max_n])

    def energy(self, x_W, u):
        return -float(u[0] * (self.direction @ self.marker.position(x_W)))

    def gradient(self, x_W, u):
        return -u[0] * self.column, None

    def mixed_derivative(self, x_W, u):
        return -self.column[:, None]


@register_body("cylinder_with_mid_marker")
class MidMarkedCylinder(CylinderBody):
    """The description's cylinder with a second marker on its axis at mid-length."""

    def markers(self):
        nodes, weights = self.embed([self.robot.length_m / 2, 0.0, 0.0], "the mid marker")
        return super().markers() | {"mid": Marker(nodes[0], weights[0])}


@pytest.fixture(scope="module")
def both(three_cable):
    """The coarse three-cable arm with the point force on its tip as a fourth input."""
    return ArmFEM(three_cable, **MESH, actuators=["cables", ("point_force", {"direction": (0.0, 0.3, 1.0)})])


def test_registries_hold_the_built_in_concepts_and_the_toy():
    assert ACTUATORS["point_force"] is PointForce and "cables" in ACTUATORS
    assert BODIES["cylinder"] is CylinderBody
    assert MATERIALS["neo-hookean"] is NeoHookeanMaterial and MATERIALS["hyperfoam"] is HyperfoamMaterial


def test_the_material_laws_share_one_interface(both):
    assert isinstance(both.elastic, MaterialLaw)
    assert isinstance(HyperfoamMaterial(1e4, 8.0, 0.3).on_mesh(both.mesh), MaterialLaw)


def test_two_kinds_of_actuator_at_once(both, coarse_fem):
    assert [a.kind for a in both.actuators] == ["cables", "point_force"]
    assert both.n_inputs == 4 and both.input_names[-1] == "f_marker_n"
    q = coarse_fem.rest_q() + 1e-3 * np.sin(np.arange(coarse_fem.n_free))
    u3 = np.array([1.0, 0.3, 0.0])
    u4 = np.r_[u3, 0.0]
    # With no force, the cables' part is the cables-only model's to the last bit.
    assert both.energy(q, u4) == coarse_fem.energy(q, u3)
    assert np.array_equal(both.gradient(q, u4), coarse_fem.gradient(q, u3))
    assert np.array_equal(both.hessian(q, u4).toarray(), coarse_fem.hessian(q, u3).toarray())
    assert np.array_equal(both.mixed_derivative(q, u4)[:, :3], coarse_fem.mixed_derivative(q, u3))
    a, b = solve_static(both, u4), solve_static(coarse_fem, u3)
    assert np.array_equal(a.q, b.q) and a.iterations == b.iterations
    assert len(both.input_states(q, u4)) == 4
    with pytest.raises(InputError):
        both.check_input([1.0, 0.0, 0.0, 1.0])  # 1 N: outside the toy's bounds
    with pytest.raises(InputError):
        both.check_input([1.0, 0.0, 0.0])


def test_point_force_solves_to_equilibrium_and_pushes_its_marker(both):
    u0, u = np.array([1.0, 0.3, 0.0, 0.0]), np.array([1.0, 0.3, 0.0, 0.02])
    rest, pushed = solve_static(both, u0), solve_static(both, u, sensitivity=True)
    assert pushed.converged
    assert np.abs(both.gradient(pushed.q, u)).max() < 1e-8
    push = pushed.p_tip_W - rest.p_tip_W
    assert push @ both.actuators[1].direction > 1e-4  # the tip moves along the force


def test_point_force_derivatives_match_differences_and_autograd(both):
    fem, act = both, both.actuators[1]
    rng = np.random.default_rng(3)
    q = fem.rest_q() + 2e-3 * rng.standard_normal(fem.n_free)
    u = np.array([1.0, 0.3, 0.0, 0.02])
    x = fem.to_nodes(q)
    # The toy's own gradient against autograd of its energy.
    x_t = torch.tensor(x, requires_grad=True)
    d = torch.tensor(act.direction)
    e = -(u[3] * d) @ (torch.tensor(act.marker.weights) @ x_t[act.marker.nodes])
    e.backward()
    assert float(e.detach()) == pytest.approx(act.energy(x, u[3:]), rel=1e-14)
    g_torch = x_t.grad.numpy().ravel()[fem.free_dofs]
    assert np.allclose(act.gradient(x, u[3:])[0], g_torch, rtol=0, atol=1e-15)
    # The model with both actuators: gradient, Hessian and mixed derivative.
    g = fem.gradient(q, u)
    assert np.abs(g - fd_jacobian(lambda z: fem.energy(z, u), q, 1e-7)).max() < 1e-6 * np.abs(g).max()
    H = fem.hessian(q, u).toarray()
    assert np.abs(H - fd_jacobian(lambda z: fem.gradient(z, u), q, 1e-7)).max() < 1e-6 * np.abs(H).max()
    M = fem.mixed_derivative(q, u)
    M_fd = fd_jacobian(lambda v: fem.gradient(q, v), u, 1e-6)
    assert np.abs(M - M_fd).max() < 1e-5 * np.abs(M).max()
    v = rng.standard_normal(fem.n_free)
    assert np.allclose(fem.hessian_operator(q, u)(v), H @ v, rtol=0, atol=1e-9 * np.abs(H @ v).max())


def test_point_force_sensitivity_matches_central_differences(both):
    u = np.array([1.0, 0.3, 0.2, 0.02])
    sol = solve_static(both, u, sensitivity=True)

    def q_of(v):
        return solve_static(both, v, sol.q, check_command=False, tol_step_m=1e-10).q

    dq_fd = fd_jacobian(q_of, u, 1e-4)
    assert np.abs(sol.dq_du - dq_fd).max() < 1e-4 * np.abs(sol.dq_du).max()
    assert np.array_equal(sensitivities(both, sol.q, u)[0], sol.dq_du)
    # From a reused factorisation, refined along the force: the generic (non-condensed) inputs.
    near = solve_static(both, u, sol.q + 1e-4 * sol.dq_du[:, 0], sensitivity="reuse", refine_du=[[0, 0, 0, 0.01]])
    col = near.dq_du[:, 3]
    assert np.abs(col - sol.dq_du[:, 3]).max() < 1e-3 * np.abs(sol.dq_du[:, 3]).max()


def test_walk_with_both_actuators(both):
    predictor = WalkPredictor(both)
    walk = [np.array([0.5, 0.1, 0.0, f]) for f in (0.0, 0.01, 0.02)]
    for u in walk:
        starts = [q for _, q in predictor.ranked(u)]
        sol = solve_static(both, u, starts[0] if starts else None, sensitivity="reuse", refine_du=[[0, 0, 0, 0.01]])
        assert sol.converged
        predictor.add(sol)
    cold = solve_static(both, walk[-1])
    assert np.abs(sol.q - cold.q).max() < 1e-8


def test_a_new_body_with_a_second_marker(three_cable, both):
    body = MidMarkedCylinder(three_cable, **MESH)
    assert BODIES["cylinder_with_mid_marker"] is MidMarkedCylinder
    fem = ArmFEM(three_cable, body=body, actuators=["cables", ("point_force", {"marker": "mid"})])
    assert set(fem.markers) == {"tip", "mid"}
    assert np.array_equal(fem.tip_matrix().toarray(), both.tip_matrix().toarray())
    mid = fem.markers["mid"]
    sag, up = solve_static(fem, [0.0, 0.0, 0.0, 0.0]), solve_static(fem, [0.0, 0.0, 0.0, 0.05])
    x0, x1 = fem.to_nodes(sag.q), fem.to_nodes(up.q)
    assert mid.position(x1)[2] - mid.position(x0)[2] > 1e-4  # pushed up at mid-length
    with pytest.raises(InputError):
        ArmFEM(three_cable, body=body, n_rings=2)
