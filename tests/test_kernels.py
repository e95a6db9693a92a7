"""The compiled element kernels (lab.fem.kernels) against the NumPy reference: energy, gradient,
element and assembled Hessians and Hessian products agree to round-off for every law, on
several meshes and deformed states (rest, random, repeated stretches, compressed, a solved
equilibrium), with finite differences on the compiled path too; inverted tets behave alike;
a static solve gives the same tip; and the choice of assembly, its fall-backs and the lazy
numba import."""

import copy
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from helpers import fd_jacobian, subprocess_env
from scipy.spatial.transform import Rotation

from lab.description import load_robot
from lab.errors import InputError
from lab.fem import ArmFEM, solve_static
from lab.fem.bodies.mesh import TetMesh
from lab.fem.kernels import backend, compiled_law, set_assembly, use_assembly
from lab.fem.materials import HyperfoamMaterial, InvertedElementError, YeohMaterial
from lab.fem.materials.hyperfoam import REPEATED_LOG_GAP, Hyperfoam
from lab.fem.materials.neo_hookean import NeoHookean

ROOT = Path(__file__).resolve().parent.parent
#: Materials of the arms compared (None: the description's neo-Hookean law).
MATERIALS = {
    "neo-hookean": None,
    "yeoh": YeohMaterial(2.0e4, -1.0e3, 5.0e2, poisson_ratio=0.45),
    "hyperfoam": HyperfoamMaterial(1.4e4, 13.96, 0.75),
    "hyperfoam beta=0": HyperfoamMaterial(1.4e4, 8.5, 0.0),
    "hyperfoam alpha<0": HyperfoamMaterial(1.4e4, -4.0, 0.3),
}


def close(a, b, rtol=1e-13):
    """a equals b to round-off: relative to b's largest entry."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and np.abs(a - b).max() <= rtol * max(np.abs(b).max(), 1e-300)


def both(fn):
    """fn() with the reference and with the compiled assembly."""
    with use_assembly("numpy"):
        ref = fn()
    with use_assembly("compiled"):
        new = fn()
    return ref, new


def states(fem):
    rng = np.random.default_rng(7)
    q0 = fem.rest_q()
    axial = fem.to_free(fem.X_W * np.array([1.05, 0.98, 0.98]))  # uniaxial: repeated stretches
    return {"rest": q0, "random": q0 + 3e-4 * rng.standard_normal(fem.n_free), "uniaxial": axial}


@pytest.fixture(scope="module", params=list(MATERIALS))
def arm(request, three_cable):
    return ArmFEM(three_cable, n_rings=2, n_axial=6, material=MATERIALS[request.param])


@pytest.mark.parametrize("state", ["rest", "random", "uniaxial"])
def test_arm_energy_gradient_and_hessians_agree(arm, state):
    u = np.array([2.0, 0.7, 0.1])
    q = states(arm)[state]
    v = np.random.default_rng(3).standard_normal(arm.n_free)
    with use_assembly("compiled"):
        assert compiled_law(arm.elastic) is not None
    (E0, g0, _), (E1, g1, _) = both(lambda: arm.energy(q, u, with_gradient=True))
    assert abs(E1 - E0) <= 1e-13 * abs(E0) and close(g1, g0, 1e-12)
    assert close(*both(lambda: arm.gradient(q, u)), 1e-12)
    assert both(lambda: arm.energy(q, u))[1] == E1
    H0, H1 = both(lambda: arm.hessian(q, u))
    assert np.array_equal(H0.indptr, H1.indptr) and np.array_equal(H0.indices, H1.indices)
    assert close(H1.data, H0.data)
    F0, F1 = both(lambda: arm.energy(q, u, with_hessian=True))  # energy, gradient and Hessian in one pass
    assert (F0[0], F1[0]) == (E0, E1) and np.array_equal(F0[1], g0) and np.array_equal(F1[1], g1)
    assert np.array_equal(F0[3].data, H0.data) and np.array_equal(F1[3].data, H1.data)
    P0, P1 = both(lambda: arm.hessian(q, u, project=True))
    assert close(P1.data, P0.data, 1e-12)
    assert close(*both(lambda: arm.hessian_operator(q, u)(v)))


def test_element_hessians_agree_at_a_solved_equilibrium(arm):
    u = np.array([2.0, 0.0, 1.0])
    with use_assembly("numpy"):
        x = arm.to_nodes(solve_static(arm, u).q)
    with use_assembly("compiled"):
        law = compiled_law(arm.elastic)
    assert close(law.hessian(x), arm.elastic.hessian(x))
    assert close(law.nodal_gradient(x), arm.elastic.nodal_gradient(x), 1e-12)


@pytest.mark.parametrize("material", ["yeoh", "hyperfoam", "hyperfoam alpha<0"])
def test_compiled_derivatives_match_finite_differences(material, three_cable):
    fem = ArmFEM(three_cable, n_rings=1, n_axial=4, material=MATERIALS[material])
    q = fem.rest_q() + 2e-3 * np.random.default_rng(1).standard_normal(fem.n_free)
    u = np.array([2.0, 0.7, 0.1])
    with use_assembly("compiled"):
        g = fem.gradient(q, u)
        assert np.abs(g - fd_jacobian(lambda z: fem.energy(z, u), q, 1e-7)).max() < 1e-6 * np.abs(g).max()
        H = fem.hessian(q, u).toarray()
        assert np.abs(H - fd_jacobian(lambda z: fem.gradient(z, u), q, 1e-7)).max() < 1e-6 * np.abs(H).max()


#: Deformation gradients of one tet: the foam law's special cases (tests/test_hyperfoam.py's).
R1, R2 = Rotation.from_rotvec([0.3, -0.5, 0.8]).as_matrix(), Rotation.from_rotvec([-0.7, 0.2, 0.4]).as_matrix()
ONE_TET_STATES = {
    "rest": np.eye(3),
    "far": np.eye(3) + 0.3 * np.random.default_rng(5).standard_normal((3, 3)),
    "uniaxial (double)": R1 @ np.diag([1.5, 0.8, 0.8]) @ R2,
    "gap below the limit": R1 @ np.diag([1.5, 0.8, 0.8 * (1 + 0.4 * REPEATED_LOG_GAP)]) @ R2,
    "gap above the limit": R1 @ np.diag([1.5, 0.8, 0.8 * (1 + 0.6 * REPEATED_LOG_GAP)]) @ R2,
    "dilation (triple)": 1.2 * R1,
    "compressed": R1 @ np.diag([0.4, 0.9, 1.1]) @ R2,
}
ONE_TET = TetMesh(np.array([[0.0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]), np.array([[0, 1, 2, 3]]))
ONE_TET_LAWS = {
    "neo-hookean": lambda: NeoHookean.from_mesh(ONE_TET, 5e4, 0.4),
    "yeoh": lambda: YeohMaterial(2.0e4, -1.0e3, 5.0e2, poisson_ratio=0.45).on_mesh(ONE_TET),
    "hyperfoam": lambda: Hyperfoam.from_mesh(ONE_TET, 1.4e4, 13.96, 0.75),
    "hyperfoam beta=0": lambda: Hyperfoam.from_mesh(ONE_TET, 1.4e4, 8.5, 0.0),
}


@pytest.mark.parametrize("law", list(ONE_TET_LAWS))
@pytest.mark.parametrize("state", list(ONE_TET_STATES))
def test_one_element_at_repeated_and_extreme_stretches(law, state):
    law = ONE_TET_LAWS[law]()
    x = ONE_TET.X_W @ ONE_TET_STATES[state].T
    with use_assembly("compiled"):
        fast = compiled_law(law)
    e0, g0 = law.energy_and_gradient(x)
    e1, g1 = fast.energy_and_gradient(x)
    assert abs(e1 - e0) <= 1e-13 * abs(e0) + 1e-300 and close(g1, g0, 1e-12)
    assert close(fast.hessian(x), law.hessian(x), 1e-12)


@pytest.mark.parametrize("material", ["neo-hookean", "yeoh", "hyperfoam"])
def test_inverted_tets_are_infinite_energy_and_errors_alike(material, three_cable):
    fem = ArmFEM(three_cable, n_rings=1, n_axial=4, material=MATERIALS[material])
    x = fem.X_W.copy()
    x[fem.mesh.tets[0, 0]] = x[fem.mesh.tets[0, 1:]].mean(axis=0) * 2 - x[fem.mesh.tets[0, 0]]  # through its face
    with use_assembly("compiled"):
        law = compiled_law(fem.elastic)
    assert law.energy(x) == fem.elastic.energy(x) == np.inf
    assert law.energy_and_gradient(x) == (np.inf, None)
    slots = fem._pattern.element_slots
    assert law.energy_gradient_hessian(x, np.zeros(fem._pattern.nnz), slots) == (np.inf, None)
    counts = []
    for sums in (law, fem.elastic):
        for method in ("nodal_gradient", "hessian"):
            with pytest.raises(InvertedElementError) as err:
                getattr(sums, method)(x)
            counts.append(err.value.count)
    assert len(set(counts)) == 1 and counts[0] >= 1


def test_static_solve_gives_the_same_tip_and_steps(three_cable):
    fem = ArmFEM(three_cable, n_rings=2, n_axial=10)
    u = np.array([2.0, 1.0, 0.5])
    ref, new = both(lambda: solve_static(fem, u, sensitivity=True))
    assert np.abs(new.p_tip_W - ref.p_tip_W).max() < 1e-12
    assert (new.iterations, new.factorizations, new.projected_steps) == (
        ref.iterations,
        ref.factorizations,
        ref.projected_steps,
    )
    assert close(new.J_tip_u, ref.J_tip_u, 1e-9)


def test_pneumatic_arm_chamber_blocks_and_yeoh():
    fem = ArmFEM(load_robot("pneumatic-arm"))
    q = fem.rest_q() + 1e-5 * np.random.default_rng(2).standard_normal(fem.n_free)
    u = np.array([2e3, 0.0, 1e3])
    H0, H1 = both(lambda: fem.hessian(q, u))
    assert close(H1.data, H0.data)
    assert close(*both(lambda: fem.gradient(q, u)), 1e-12)


def test_a_model_with_kernels_copies(three_cable):
    from lab.fem.kernels import elements, laws

    modes = ("ENERGY", "GRADIENT", "HESSIAN", "ELEMENT_HESSIANS", "TANGENTS", "GRADIENT_AND_HESSIAN")
    assert [getattr(laws, m) for m in modes] == [getattr(elements, m) for m in modes] == list(range(6))
    fem = ArmFEM(three_cable, n_rings=1, n_axial=4)
    q, u = fem.rest_q(), np.array([1.0, 0.0, 0.0])
    with use_assembly("compiled"):
        g = fem.gradient(q, u)
        assert np.array_equal(copy.deepcopy(fem).gradient(q, u), g)


def test_cable_blocks_embed_as_the_embedding_matrix_does(coarse_fem):
    route = coarse_fem.actuators[0].routes[0]
    n = 3 * len(route.nodes)
    H_p = np.random.default_rng(4).standard_normal((n, n))
    W = route.embedding_matrix()
    assert close(route.embed_hessian(H_p), W.T @ H_p @ W)


def test_choice_of_assembly(three_cable):
    previous = set_assembly("numpy")
    try:
        assert backend.assembly_backend(10**6) == "numpy"
        with use_assembly("compiled"):
            assert backend.assembly_backend(10) == "compiled"
        assert backend.assembly_backend() == "numpy"
        with pytest.raises(InputError, match="assembly 'fast'"):
            set_assembly("fast")
    finally:
        set_assembly(previous)
    with use_assembly(None):  # the default: small meshes keep NumPy, large ones compile
        assert backend.assembly_backend(backend.COMPILED_MIN_TETS - 1) == "numpy"
        assert backend.assembly_backend(backend.COMPILED_MIN_TETS) == "compiled"
        fem = ArmFEM(three_cable, n_rings=1, n_axial=4)
        assert fem._sums() is fem.elastic


def test_without_numba_the_numpy_assembly_is_used_with_one_warning(monkeypatch, coarse_fem):
    monkeypatch.setattr(backend, "_numba_problem", "ModuleNotFoundError: No module named 'numba'")
    monkeypatch.setattr(backend, "_warned", set())
    with use_assembly("compiled"), warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        assert coarse_fem._sums() is coarse_fem.elastic and compiled_law(coarse_fem.elastic) is None
        coarse_fem.gradient(coarse_fem.rest_q(), np.zeros(3))
    said = [w for w in said if issubclass(w.category, backend.KernelFallbackWarning)]
    assert len(said) == 1 and "numba is unavailable" in str(said[0].message)


def test_uncachable_kernels_are_compiled_with_one_warning(monkeypatch):
    import numba

    real = numba.njit

    def njit(**options):
        if options.get("cache"):
            raise RuntimeError("cannot cache function 'f': no locator available for file 'x.py'")
        return real(**options)

    monkeypatch.setattr(numba, "njit", njit)
    monkeypatch.setattr(backend, "_warned", set())
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        f = backend.jit(lambda a: a + 1.0)
        g = backend.jit(lambda a: a * 2.0)
    assert f(1.0) == 2.0 and g(2.0) == 4.0
    said = [w for w in said if issubclass(w.category, backend.KernelFallbackWarning)]
    assert len(said) == 1 and "NUMBA_CACHE_DIR" in str(said[0].message)


@pytest.mark.parametrize(
    "code",
    [
        "import runpy, sys; sys.argv = ['lab', '--help']\ntry:\n    runpy.run_module('lab', run_name='__main__')\n"
        "except SystemExit:\n    pass",
        "from lab.description import load_robot; from lab.fem import ArmFEM; ArmFEM(load_robot('three-cable'))",
    ],
    ids=["lab --help", "building a model"],
)
def test_numba_is_imported_only_to_solve(code):
    probe = f"{code}\nimport sys\nprint('numba' in sys.modules)"
    env = subprocess_env() | {"PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False", out.stdout + out.stderr
