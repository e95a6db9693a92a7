"""Sparse direct solvers for the Newton and sensitivity systems.

``factorize(H)`` returns an object with ``solve(b)`` for one or many right-hand sides.
Backends, picked by ``benchmarks/bench_fem.py`` on this project's meshes:

* ``"pardiso"`` — MKL PARDISO through ``pypardiso`` (pip-installable), real symmetric
  indefinite mode, so it factorises the exact (possibly indefinite) Hessian;
* ``"splu"`` — SciPy's SuperLU, always available, the fallback.

``LAB_LINEAR_SOLVER`` selects one by name; the default is PARDISO where MKL loads. Where
it cannot (Apple-silicon Macs, a broken MKL), the default falls back to SciPy with one
:class:`SolverFallbackWarning` per process, naming the reason; the results agree to
round-off, only slower. ``LAB_LINEAR_SOLVER=splu`` chooses SciPy and silences it.
"""

from __future__ import annotations

import os

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from lab.errors import InputError, LabRuntimeError


class SingularMatrixError(LabRuntimeError):
    pass


class SolverFallbackWarning(RuntimeWarning):
    """PARDISO (MKL) could not be used; the SciPy solver is used instead."""


#: Why PARDISO cannot be used in this process (None: not known to fail).
_pardiso_problem: str | None = None
_warned = False
#: Whether PARDISO has factorised a matrix in this process: after that, a failure is an
#: error of its own (raised), not a missing MKL (fallen back from).
_pardiso_worked = False


def _fall_back(reason: str) -> None:
    """Remember that PARDISO failed and say so once per process."""
    global _pardiso_problem, _warned
    _pardiso_problem = reason
    if not _warned:
        _warned = True
        import warnings

        warnings.warn(
            f"MKL PARDISO is unavailable ({reason}); using SciPy's SuperLU instead (same results, slower). "
            "Set LAB_LINEAR_SOLVER=splu to choose it and silence this warning.",
            SolverFallbackWarning,
            stacklevel=3,
        )


class _SuperLU:
    name = "splu"
    n_negative = None  # LU does not report the inertia

    def __init__(self, H: sp.csr_matrix):
        try:
            # The matrix is symmetric: an ordering of A + A^T keeps the fill low.
            self._lu = spla.splu(
                H.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
            )
        except RuntimeError as err:  # "Factor is exactly singular"
            raise SingularMatrixError(str(err)) from None

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._lu.solve(np.asarray(b, dtype=float))


class _Pardiso:
    """One PARDISO handle per process, reused (finding and loading MKL costs ~10 ms):
    a factorisation stays valid until the next call to :func:`factorize`.

    The symbolic analysis (fill-reducing ordering, phase 11) depends only on the
    sparsity pattern, which is fixed for a mesh, so it runs once per pattern and each
    Newton iteration pays for the numerical factorisation (phase 22) alone: about half
    the cost of analysis + factorisation on the default mesh. This drives pypardiso's
    ``PyPardisoSolver`` through its phase interface (pinned pypardiso 0.4.7).
    """

    name = "pardiso"
    _solver = None
    _generation = 0  # which factorisation the shared handle holds
    _pattern = None  # (indptr, indices) the stored symbolic analysis belongs to

    def __init__(self, H: sp.csr_matrix):
        import pypardiso

        if _Pardiso._solver is None:
            _Pardiso._solver = pypardiso.PyPardisoSolver(mtype=-2)  # real symmetric indefinite
        self._A = sp.triu(H, format="csr")
        self._A.sort_indices()
        self._factorize()
        # Inertia from the LDL^T factorisation: tells an indefinite Hessian apart.
        self.n_negative = int(self._solver.get_iparm(23))
        self.n_perturbed = int(self._solver.get_iparm(14))  # pivots PARDISO had to perturb
        if int(self._solver.get_iparm(30)) != 0:
            raise SingularMatrixError("PARDISO found a zero pivot")
        global _pardiso_worked
        _pardiso_worked = True

    def _factorize(self):
        import pypardiso

        solver, A = self._solver, self._A
        try:
            solver._check_A(A)
        except ValueError as err:  # "Matrix A is singular, because it contains empty row(s)"
            if "singular" not in str(err):
                raise
            raise SingularMatrixError(str(err)) from None
        known = _Pardiso._pattern
        same = known is not None and np.array_equal(known[0], A.indptr) and np.array_equal(known[1], A.indices)
        solver.set_phase(22 if same else 12)  # numerical only, or analysis + numerical
        try:
            solver._call_pardiso(A, np.zeros((A.shape[0], 1)))
        except pypardiso.pardiso_wrapper.PyPardisoError as err:
            _Pardiso._pattern = None
            raise SingularMatrixError(str(err)) from None
        if not same:
            _Pardiso._pattern = (A.indptr.copy(), A.indices.copy())
        _Pardiso._generation += 1
        self._generation = _Pardiso._generation

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self._generation != _Pardiso._generation:  # the handle now holds another matrix
            self._factorize()
        b = np.asarray(b, dtype=float)
        rhs = np.asfortranarray(b.reshape(len(b), -1))
        # Iterative refinement (two steps, PARDISO's default) only after perturbed
        # pivots: otherwise the direct solution is already accurate to ~1e-12 relative
        # and the two extra solves would triple the cost of each solve.
        self._solver.set_iparm(8, 2 if self.n_perturbed else 0)
        self._solver.set_phase(33)
        x = self._solver._call_pardiso(self._A, rhs)
        return x.reshape(b.shape)


def _available() -> list[str]:
    if _pardiso_problem is None:
        try:
            import pypardiso  # noqa: F401
        except Exception as err:  # ImportError, or OSError when MKL's libraries do not load
            _fall_back(f"import pypardiso failed: {type(err).__name__}: {err}")
    return (["pardiso"] if _pardiso_problem is None else []) + ["splu"]


BACKENDS = {"splu": _SuperLU, "pardiso": _Pardiso}


def default_backend() -> str:
    """The sparse solver :func:`factorize` uses: ``LAB_LINEAR_SOLVER`` if set, else PARDISO
    when it can be loaded, else SciPy's SuperLU.

    Returns
    -------
    str
        ``"pardiso"`` or ``"splu"`` (InputError for an unknown ``LAB_LINEAR_SOLVER``).
    """
    choice = os.environ.get("LAB_LINEAR_SOLVER")
    if choice:
        if choice not in BACKENDS:
            raise InputError(f"LAB_LINEAR_SOLVER={choice!r}: choose one of {sorted(BACKENDS)}")
        return choice
    return _available()[0]


def factorize(H: sp.csr_matrix, backend: str | None = None):
    """Factorise a sparse symmetric matrix; raises SingularMatrixError if singular.

    With the default backend, a PARDISO that fails before it has ever worked in this
    process (MKL not loadable) falls back to SciPy for the rest of the process, with one
    warning; once it has worked, its errors are raised.

    Parameters
    ----------
    H : scipy.sparse.csr_matrix, shape (n, n)
        The symmetric matrix (a Hessian, N/m).
    backend : str, optional
        ``"pardiso"`` or ``"splu"``; default :func:`default_backend`.

    Returns
    -------
    object
        The factorisation: ``solve(b)`` gives H^-1 b for ``b`` (n,) or (n, k), and
        ``n_negative`` the number of negative eigenvalues (None where unknown). A PARDISO
        factorisation stays valid until the next call.
    """
    name = backend or default_backend()
    if name != "pardiso" or backend is not None or os.environ.get("LAB_LINEAR_SOLVER"):
        return BACKENDS[name](H)
    try:
        return _Pardiso(H)
    except SingularMatrixError:
        raise
    except Exception as err:  # e.g. OSError: MKL's libraries do not load on this machine
        if _pardiso_worked:
            raise
        _fall_back(f"PARDISO failed: {type(err).__name__}: {err}")
        return _SuperLU(H)
