"""PARDISO's Cholesky-first mode against LDL^T only, and MKL found without a directory walk."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import lab.fem.solve.linsolve as linsolve
from lab.fem.solve import mkl, pardiso_calls
from lab.fem.solve.steps import newton_step, shifted_step

ROOT = Path(__file__).resolve().parent.parent
U = np.array([0.6, 0.2, 0.0])


@pytest.fixture
def pardiso(monkeypatch):
    if "pardiso" not in linsolve._available():
        pytest.skip("pypardiso not installed")
    monkeypatch.delenv("LAB_LINEAR_SOLVER", raising=False)
    monkeypatch.setattr(linsolve, "PARDISO_MODE", "definite-first")


@pytest.fixture
def hessians(coarse_fem):
    """The coarse arm's Hessian at rest (positive definite) and shifted to be indefinite."""
    H = coarse_fem.hessian(coarse_fem.rest_q(), U).tocsr()
    eig = np.linalg.eigvalsh(H.toarray())
    assert eig[0] > 0
    shift = 0.5 * (eig[2] + eig[3])  # three negative eigenvalues
    return H, (H - shift * sp.eye(H.shape[0])).tocsr()


def factorise_in(mode, H, monkeypatch):
    monkeypatch.setattr(linsolve, "PARDISO_MODE", mode)
    return linsolve.factorize(H)


def test_the_modes_agree_on_a_definite_and_an_indefinite_matrix(pardiso, hessians, monkeypatch):
    b = np.random.default_rng(0).standard_normal((hessians[0].shape[0], 4))
    for H, n_negative in zip(hessians, (0, 3)):
        fallbacks = linsolve._Pardiso.fallbacks
        new = factorise_in("definite-first", H, monkeypatch)
        x_new = new.solve(b)
        fell_back = linsolve._Pardiso.fallbacks - fallbacks
        old = factorise_in("indefinite", H, monkeypatch)
        x_old = old.solve(b)
        assert old.mtype == -2 and (new.mtype, fell_back) == ((2, 0) if n_negative == 0 else (-2, 1))
        assert new.n_negative == old.n_negative == n_negative  # the inertia signal Newton tests
        assert np.linalg.norm(x_new - x_old) <= 1e-12 * np.linalg.norm(x_old)
        assert np.linalg.norm(H @ x_new - b) <= 1e-12 * abs(H).max() * np.linalg.norm(x_new)


def test_newton_and_shifted_steps_see_the_same_inertia_in_both_modes(pardiso, hessians, monkeypatch):
    H = hessians[0]
    eig = np.linalg.eigvalsh(H.toarray())[:2]
    dip = min(0.5 * (eig[1] - eig[0]), 1e-4 * np.median(H.diagonal()))  # the first shift makes it definite
    indefinite = (H - (eig[0] + dip) * sp.eye(H.shape[0])).tocsr()  # one eigenvalue -dip
    g = np.random.default_rng(1).standard_normal(H.shape[0])
    steps = {}
    for mode in ("indefinite", "definite-first"):
        monkeypatch.setattr(linsolve, "PARDISO_MODE", mode)
        assert newton_step(indefinite, g, None) == (None, None)  # indefinite: no Newton step
        d, _ = newton_step(H, g, None)
        shifted, used = shifted_step(indefinite.copy(), g)
        steps[mode] = d, shifted, used
    (d_old, s_old, n_old), (d_new, s_new, n_new) = steps.values()
    assert np.linalg.norm(d_new - d_old) <= 1e-12 * np.linalg.norm(d_old)
    assert n_new == n_old == 1 and np.linalg.norm(s_new - s_old) <= 1e-12 * np.linalg.norm(s_old)


def test_a_stale_factorisation_is_redone_and_one_handle_holds_a_factor(pardiso, hessians):
    H, indefinite = hessians
    b = np.arange(H.shape[0], dtype=float)
    assert H.nnz != indefinite.nnz  # H stores zeros: another pattern, analysed anew
    definite = linsolve.factorize(H)  # Cholesky
    linsolve.factorize(indefinite)  # LDL^T, after a failed Cholesky (which analysed its pattern)
    assert sum(h.holds_factor for h in linsolve._Pardiso._handles.values()) == 1
    x = definite.solve(b)  # factorised again
    assert np.linalg.norm(H @ x - b) <= 1e-12 * abs(H).max() * np.linalg.norm(x)
    assert sum(h.holds_factor for h in linsolve._Pardiso._handles.values()) == 1


def test_a_cholesky_factor_solves_in_halves(pardiso, hessians):
    """forward then backward is the whole solve, and b^T H^-1 c = forward(b) . forward(c)
    (the condensed step's C = Y^T Y); only a Cholesky factor has the halves, and a half
    after another factorisation factorises its matrix again, as a whole solve does."""
    H, indefinite = hessians
    B = np.random.default_rng(5).standard_normal((H.shape[0], 4))
    lu = linsolve.factorize(H)
    assert lu.mtype == 2 and lu.half_solves
    X = lu.solve(B)
    Y = lu.forward(B)
    assert Y.shape == B.shape and np.abs(Y - X).max() > 1e-3 * np.abs(X).max()  # not the solve itself
    assert np.abs(lu.backward(Y) - X).max() <= 1e-13 * np.abs(X).max()
    assert np.abs(Y.T @ Y - B.T @ X).max() <= 1e-12 * np.abs(B.T @ X).max()
    assert np.abs(lu.backward(lu.forward(B[:, 0])) - X[:, 0]).max() <= 1e-13 * np.abs(X).max()  # one column
    ldlt = linsolve.factorize(indefinite)
    assert not ldlt.half_solves and not lu.current  # LDL^T has no halves; lu's factor is gone
    with pytest.raises(linsolve.LabRuntimeError, match="solves whole"):
        ldlt.forward(B)
    assert np.abs(lu.backward(lu.forward(B)) - X).max() <= 1e-13 * np.abs(X).max()  # H factorised again


def test_a_lazy_s_after_another_factorisation_is_a_whole_solve(pardiso, hessians, coarse_fem):
    """A condensed factorisation keeps Y = L^-1 P A; S = H^-1 A asked for after another
    matrix was factorised comes from a whole solve with H, not from Y's backward half of a
    factor made again."""
    from lab.fem.solve.steps import condensed_factorisation

    H, indefinite = hessians
    g, cond = coarse_fem.gradient(coarse_fem.rest_q(), U, with_condensation=True)
    fac, _ = condensed_factorisation(linsolve.factorize(H), g, cond)
    assert fac.Y is not None
    linsolve.factorize(indefinite)
    S = np.linalg.solve(H.toarray(), cond.A)
    assert np.abs(fac.S - S).max() <= 1e-10 * np.abs(S).max()


def test_a_condensed_step_from_halves_is_the_one_from_whole_solves(pardiso, coarse_fem, monkeypatch):
    """A Newton step of the cables' condensation with a Cholesky factor (forward halves,
    S formed only when asked) and with LDL^T (whole solves of S): the same step, C and S."""
    fem, u = coarse_fem, np.array([2.5, 0.4, 0.0])
    q = fem.rest_q() + 1e-4 * np.random.default_rng(6).standard_normal(fem.n_free)
    g, cond = fem.gradient(q, u, with_condensation=True)
    H = fem.hessian(q, u)
    out = {}
    for mode in ("definite-first", "indefinite"):
        monkeypatch.setattr(linsolve, "PARDISO_MODE", mode)
        d, fac = newton_step(H, g, cond)
        assert (fac.Y is not None) == (mode == "definite-first")
        out[mode] = d, fac.C.copy(), fac.S.copy()
    for new, old in zip(*out.values()):
        assert np.abs(new - old).max() <= 1e-11 * np.abs(old).max()


def test_an_unknown_mode_is_an_input_error(pardiso, hessians, monkeypatch):
    monkeypatch.setattr(linsolve, "PARDISO_MODE", "cholesky")
    with pytest.raises(ValueError, match="PARDISO_MODE"):
        linsolve.factorize(hessians[0])


def run_fresh(code, **env):
    """Run ``code`` in a fresh interpreter (pypardiso not yet imported), without
    ``PYPARDISO_MKL_RT`` unless given; its stdout."""
    base = {k: v for k, v in os.environ.items() if k not in ("PYPARDISO_MKL_RT", "LAB_LINEAR_SOLVER")}
    base.update(PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", **env)
    out = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], env=base, capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_mkl_is_found_without_walking_the_environment():
    pytest.importorskip("pypardiso")
    path = mkl.mkl_rt_path()
    if path is None:
        pytest.skip("MKL is not where the mkl wheel puts it")
    assert Path(path).is_file() and "mkl_rt" in Path(path).name
    out = run_fresh(
        """
        import ctypes.util, glob, os
        def refuse(*args, **kwargs):
            raise AssertionError(f"searched for MKL: {args}")
        def no_walk(plain):
            def search(pattern, *args, recursive=False, **kwargs):
                if recursive or "**" in str(pattern):
                    refuse(pattern)
                return plain(pattern, *args, **kwargs)
            return search
        glob.glob, glob.iglob = no_walk(glob.glob), no_walk(glob.iglob)
        os.walk = ctypes.util.find_library = refuse
        import numpy as np, scipy.sparse as sp
        from lab.fem.solve.linsolve import factorize
        lu = factorize(sp.csr_matrix(np.diag([1.0, 2.0, 3.0])))
        print(lu.name, lu.mtype, os.environ["PYPARDISO_MKL_RT"])
        """
    )
    assert out.split() == ["pardiso", "2", path]


def test_a_broken_mkl_path_falls_back_to_superlu_with_one_warning(tmp_path):
    pytest.importorskip("pypardiso")
    out = run_fresh(
        """
        import warnings
        import numpy as np, scipy.sparse as sp
        import lab.fem.solve.linsolve as linsolve
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            names = [linsolve.factorize(sp.csr_matrix(np.diag([1.0, 2.0]))).name for _ in range(3)]
        said = [w for w in caught if issubclass(w.category, linsolve.SolverFallbackWarning)]
        print(names, len(said), "libmkl_rt" in str(said[0].message))
        """,
        PYPARDISO_MKL_RT=str(tmp_path / "libmkl_rt.so.3"),  # a path set by the user is kept
    )
    assert out.strip() == "['splu', 'splu', 'splu'] 1 True"


def test_any_csr_layout_of_a_matrix_gives_its_solution(pardiso, hessians):
    """PARDISO reads the upper triangle through a pattern cached per sparsity pattern: a
    matrix with unsorted or duplicate entries, or a CSC or COO one, solves as its canonical
    CSR does."""
    H = hessians[0]
    n, b = H.shape[0], np.random.default_rng(1).standard_normal(H.shape[0])
    x = np.linalg.solve(H.toarray(), b)
    rows = np.repeat(np.arange(n), np.diff(H.indptr))
    flip = np.lexsort((-H.indices, rows))  # every row's columns in decreasing order
    unsorted = sp.csr_matrix((H.data[flip], H.indices[flip], H.indptr), shape=H.shape)
    doubled = np.repeat(np.arange(H.nnz), 2)  # every entry split in two halves, side by side
    duplicated = sp.csr_matrix((H.data[doubled] / 2, H.indices[doubled], 2 * H.indptr), shape=H.shape)
    assert not unsorted.has_sorted_indices and not duplicated.has_canonical_format
    for layout in (H, unsorted, duplicated, H.tocsc(), H.tocoo()):
        assert np.allclose(linsolve.factorize(layout).solve(b), x, rtol=1e-10, atol=1e-12 * np.abs(x).max())
    patterns = len(pardiso_calls.PATTERNS)
    linsolve.factorize(H.copy())  # the same pattern again: no new one
    assert len(pardiso_calls.PATTERNS) == patterns
