"""Sparse solver backends: PARDISO where MKL loads, SciPy's SuperLU otherwise (one warning)."""

import sys
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

import lab.fem.solve.linsolve as linsolve
from lab.fem import solve_static

U = np.array([0.6, 0.2, 0.0])


@pytest.fixture
def no_pardiso(monkeypatch):
    """This process as on a machine where ``import pypardiso`` fails (e.g. Apple silicon)."""
    monkeypatch.delenv("LAB_LINEAR_SOLVER", raising=False)
    monkeypatch.setitem(sys.modules, "pypardiso", None)  # the import raises ImportError
    monkeypatch.setattr(linsolve, "_pardiso_problem", None)
    monkeypatch.setattr(linsolve, "_warned", False)
    monkeypatch.setattr(linsolve, "_pardiso_worked", False)


def test_fallback_warns_once_and_solves_the_same(coarse_fem, no_pardiso, monkeypatch):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert linsolve.default_backend() == "splu"
        fallback = solve_static(coarse_fem, U)
        solve_static(coarse_fem, 0.5 * U)
    said = [w for w in caught if issubclass(w.category, linsolve.SolverFallbackWarning)]
    assert len(said) == 1 and "pypardiso" in str(said[0].message) and "LAB_LINEAR_SOLVER=splu" in str(said[0].message)
    assert fallback.converged
    monkeypatch.undo()  # back to this machine's default backend (PARDISO where it loads)
    linsolve._pardiso_problem = None
    reference = solve_static(coarse_fem, U)
    assert np.linalg.norm(fallback.p_tip_W - reference.p_tip_W) < 1e-9


def test_pardiso_failing_at_first_use_falls_back(coarse_fem, monkeypatch):
    pytest.importorskip("pypardiso")
    monkeypatch.delenv("LAB_LINEAR_SOLVER", raising=False)
    monkeypatch.setattr(linsolve, "_pardiso_problem", None)
    monkeypatch.setattr(linsolve, "_warned", False)
    monkeypatch.setattr(linsolve, "_pardiso_worked", False)

    def broken(self, H):
        raise OSError("libmkl_rt.so: cannot open shared object file")

    monkeypatch.setattr(linsolve._Pardiso, "__init__", broken)
    with pytest.warns(linsolve.SolverFallbackWarning, match="libmkl_rt"):
        sol = solve_static(coarse_fem, U)
    assert sol.converged and linsolve.default_backend() == "splu"
    monkeypatch.undo()
    assert np.linalg.norm(sol.p_tip_W - solve_static(coarse_fem, U).p_tip_W) < 1e-9


def test_pardiso_failing_after_it_worked_is_an_error_not_a_fallback(coarse_fem, monkeypatch):
    pytest.importorskip("pypardiso")
    monkeypatch.delenv("LAB_LINEAR_SOLVER", raising=False)
    monkeypatch.setattr(linsolve, "_pardiso_problem", None)
    monkeypatch.setattr(linsolve, "_warned", False)
    monkeypatch.setattr(linsolve, "_pardiso_worked", False)
    H = coarse_fem.hessian(coarse_fem.to_free(coarse_fem.mesh.X_W), U)
    assert linsolve.factorize(H).name == "pardiso" and linsolve._pardiso_worked

    def broken(self, H):
        raise MemoryError("out of memory")

    monkeypatch.setattr(linsolve._Pardiso, "__init__", broken)
    with warnings.catch_warnings():
        warnings.simplefilter("error", linsolve.SolverFallbackWarning)
        with pytest.raises(MemoryError):
            linsolve.factorize(H)
    assert linsolve.default_backend() == "pardiso"


def test_a_matrix_with_an_empty_row_is_singular_not_a_fallback(monkeypatch):
    pytest.importorskip("pypardiso")
    monkeypatch.delenv("LAB_LINEAR_SOLVER", raising=False)
    monkeypatch.setattr(linsolve, "_pardiso_problem", None)
    monkeypatch.setattr(linsolve, "_warned", False)
    monkeypatch.setattr(linsolve, "_pardiso_worked", False)  # even as the first use
    H = sp.csr_matrix(np.diag([1.0, 0.0, 2.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", linsolve.SolverFallbackWarning)
        for backend in (None, "pardiso", "splu"):
            with pytest.raises(linsolve.SingularMatrixError):
                linsolve.factorize(H, backend)
    assert linsolve.default_backend() == "pardiso"


def test_chosen_backend_is_never_replaced(monkeypatch):
    monkeypatch.setenv("LAB_LINEAR_SOLVER", "nonsense")
    with pytest.raises(ValueError, match="LAB_LINEAR_SOLVER"):
        linsolve.default_backend()
