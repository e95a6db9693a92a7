"""Sparse direct solvers for the Newton and sensitivity systems.

``factorize(H)`` returns an object with ``solve(b)`` for one or many right-hand sides and
``n_negative``, the number of H's negative eigenvalues, which tells the Newton solver an
indefinite Hessian apart. Backends, picked by ``benchmarks/bench_fem.py`` on this
project's meshes:

* ``"pardiso"`` — MKL PARDISO through ``pypardiso`` (pip-installable). It tries a
  Cholesky factorisation first (``mtype`` 2, faster than LDL^T on the arms' Hessians:
  ``benchmarks/bench_linsolve.txt``); where PARDISO meets a non-positive pivot (error
  -4: the matrix is not positive definite) it factorises that matrix again as real
  symmetric indefinite (``mtype`` -2, LDL^T), whose inertia gives ``n_negative``. So it
  factorises the exact (possibly indefinite) Hessian; an indefinite one costs a failed
  Cholesky more.
  :data:`PARDISO_MODE` ``= "indefinite"`` goes straight to LDL^T (the previous
  behaviour; the same results to round-off);
* ``"splu"`` — SciPy's SuperLU, always available, the fallback.

MKL's library is located without a directory walk (:mod:`lab.fem.solve.mkl`), so the
first factorisation in a process (each worker, notebook kernel, command) does not pay
``pypardiso``'s own search (about a second of CPU time on this project's environment).

``LAB_LINEAR_SOLVER`` selects one by name; the default is PARDISO where MKL loads. Where
it cannot (Apple-silicon Macs, a broken MKL), the default falls back to SciPy with one
:class:`SolverFallbackWarning` per process, naming the reason; the results agree to
round-off, only slower. ``LAB_LINEAR_SOLVER=splu`` chooses SciPy and silences it.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from lab.errors import InputError, LabRuntimeError
from lab.fem.solve import mkl
from lab.fem.solve.pardiso_calls import call as _call
from lab.fem.solve.pardiso_calls import upper_pattern as _upper_pattern


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
    half_solves = False  # no forward and backward halves

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


def _pypardiso():
    """``import pypardiso``, pointed at MKL's library first (:mod:`.mkl`: no directory walk)."""
    if "pypardiso" not in sys.modules:
        mkl.point_pypardiso_at_mkl()
    import pypardiso

    return pypardiso


#: How PARDISO factorises, in-process (for benchmarks and tests): ``"definite-first"``
#: (the default) tries Cholesky (``mtype`` 2) and, where PARDISO reports a non-positive
#: pivot, factorises that matrix again as real symmetric indefinite (LDL^T with
#: Bunch-Kaufman pivoting, ``mtype`` -2, whose inertia counts its negative eigenvalues);
#: ``"indefinite"`` goes straight to LDL^T (the previous behaviour). Both give the same
#: solutions (to round-off) and the same ``n_negative`` test.
PARDISO_MODE = "definite-first"
PARDISO_MODES = {"definite-first": (2, -2), "indefinite": (-2,)}


class _Handle:
    """One ``PyPardisoSolver`` (one PARDISO handle) for one matrix type, and the sparsity
    pattern its symbolic analysis belongs to."""

    def __init__(self, mtype: int):
        self.solver = _pypardiso().PyPardisoSolver(mtype=mtype)
        self.pattern = None  # the UpperPattern analysed last (lab.fem.solve.pardiso_calls)
        self.holds_factor = False

    def free_factor(self):
        """Release the numerical factor (PARDISO phase 0; the analysis is kept)."""
        if self.holds_factor:
            self.solver.set_phase(0)
            self.solver._call_pardiso(sp.csr_matrix((0, 0)), np.zeros(0))
            self.holds_factor = False


class _Pardiso:
    """PARDISO handles kept for the process, one per matrix type (loading MKL and the
    symbolic analysis are paid once): a factorisation stays valid until the next call to
    :func:`factorize` (after that, its ``solve`` factorises its matrix again).

    The symbolic analysis (fill-reducing ordering, phase 11) depends only on the
    sparsity pattern, which is fixed for a mesh, so it runs once per pattern and handle,
    and each Newton iteration pays for the numerical factorisation (phase 22) alone:
    about half the cost of analysis + factorisation on the default mesh. A Cholesky
    factorisation that fails on a non-positive pivot keeps its handle's analysis. Only
    one handle holds a numerical factor at a time (the others' are freed). This drives
    pypardiso's ``PyPardisoSolver`` through its phase interface (pinned pypardiso 0.4.7).
    """

    name = "pardiso"
    _handles: dict[int, _Handle] = {}
    _generation = 0  # which factorisation the handles hold
    #: Factorisations begun in ``"definite-first"`` mode that found the matrix not positive
    #: definite and fell back to LDL^T (a count for benchmarks).
    fallbacks = 0

    def __init__(self, H: sp.csr_matrix, mode: str | None = None):
        mode = PARDISO_MODE if mode is None else mode
        if mode not in PARDISO_MODES:
            raise InputError(f"PARDISO_MODE={mode!r}: choose one of {sorted(PARDISO_MODES)}")
        self._upper, H = _upper_pattern(H)
        self._data = np.take(H.data, self._upper.take)  # the upper triangle's entries, in PARDISO's order
        pypardiso = _pypardiso()
        *first, last = PARDISO_MODES[mode]
        for mtype in first:
            try:
                self._factorize(mtype)
                break
            except pypardiso.pardiso_wrapper.PyPardisoError:  # -4: a non-positive pivot (any other
                _Pardiso.fallbacks += 1  # failure too: LDL^T then decides, as it did before)
        else:
            try:
                self._factorize(last)
            except pypardiso.pardiso_wrapper.PyPardisoError as err:
                raise SingularMatrixError(str(err)) from None
        solver = self._solver
        # Inertia from the LDL^T factorisation tells an indefinite Hessian apart; a
        # Cholesky factorisation exists only for a positive definite one.
        self.n_negative = 0 if self.mtype == 2 else int(solver.get_iparm(23))
        self.n_perturbed = int(solver.get_iparm(14))  # pivots PARDISO had to perturb
        if int(solver.get_iparm(30)) != 0:
            raise SingularMatrixError("PARDISO found a zero pivot")
        global _pardiso_worked
        _pardiso_worked = True

    @classmethod
    def forget_analysis(cls) -> None:
        """Make the next factorisation analyse the pattern again (phase 12; benchmarks)."""
        for handle in cls._handles.values():
            handle.pattern = None

    def _factorize(self, mtype: int):
        """Factorise the upper triangle ``self._data`` with the handle of ``mtype`` (PyPardisoError
        if PARDISO fails)."""
        handle = _Pardiso._handles.get(mtype)
        if handle is None:
            handle = _Pardiso._handles[mtype] = _Handle(mtype)
        solver, upper = handle.solver, self._upper
        if not self._upper.full_rows:  # PARDISO would crash on an empty row
            raise SingularMatrixError("Matrix A is singular, because it contains empty row(s)")
        solver.set_iparm(12, 0)  # CSR, not its transpose
        _Pardiso._generation += 1  # whatever a handle held is gone from here on
        self._generation, self.mtype, self._solver = _Pardiso._generation, mtype, solver
        same = handle.pattern is upper  # the analysis of this pattern (one object per pattern)
        solver.set_phase(22 if same else 12)  # numerical only, or analysis + numerical
        solver.iparm[29] = 0  # iparm(30), where a Cholesky met a non-positive pivot: not reset by PARDISO
        handle.holds_factor = True
        try:
            _call(solver, upper, self._data, np.zeros((len(upper.indptr) - 1, 1), order="F"))
        except Exception as err:
            # A Cholesky that met a non-positive pivot (-4) has analysed this pattern.
            analysed = mtype == 2 and getattr(err, "value", None) == -4
            handle.pattern = upper if analysed else None
            raise
        handle.pattern = upper
        for other in _Pardiso._handles.values():
            if other is not handle:
                other.free_factor()

    def solve(self, b: np.ndarray) -> np.ndarray:
        """H^-1 b for ``b`` (n,) or (n, k)."""
        return self._phase(33, b)

    @property
    def half_solves(self) -> bool:
        """Whether :meth:`forward` and :meth:`backward` are available: a Cholesky factor
        H = P^T L L^T P (``mtype`` 2; LDL^T would need its diagonal between the halves)."""
        return self.mtype == 2

    @property
    def current(self) -> bool:
        """Whether the handles still hold this factor: a forward half from before a later
        :func:`factorize` meets the backward half of a factor made again, the same only
        where the analysis is (a caller that cannot tell solves whole)."""
        return self._generation == _Pardiso._generation

    def forward(self, b: np.ndarray) -> np.ndarray:
        """y = L^-1 P b (PARDISO's forward substitution alone, half a solve): H^-1 b is
        ``backward(y)`` and b^T H^-1 c = y_b . y_c (only where :attr:`half_solves`)."""
        return self._phase(331, b)

    def backward(self, y: np.ndarray) -> np.ndarray:
        """P^T L^-T y (the backward substitution alone): ``backward(forward(b))`` = H^-1 b."""
        return self._phase(333, y)

    def _phase(self, phase: int, b: np.ndarray) -> np.ndarray:
        """PARDISO's solve ``phase`` (33 whole, 331 forward, 333 backward) on ``b``."""
        if phase != 33 and not self.half_solves:
            raise LabRuntimeError(f"PARDISO phase {phase}: an LDL^T factor solves whole (half_solves is False)")
        if self._generation != _Pardiso._generation:  # the handles now hold another matrix
            try:
                self._factorize(self.mtype)
            except _pypardiso().pardiso_wrapper.PyPardisoError as err:
                raise SingularMatrixError(str(err)) from None
        b = np.asarray(b, dtype=float)
        rhs = np.asfortranarray(b.reshape(len(b), -1))
        # Iterative refinement (two steps, PARDISO's default) only after perturbed
        # pivots: otherwise the direct solution is already accurate to ~1e-12 relative
        # and the two extra solves would triple the cost of each solve.
        self._solver.set_iparm(8, 2 if self.n_perturbed and phase == 33 else 0)
        self._solver.set_phase(phase)
        x = _call(self._solver, self._upper, self._data, rhs)
        return x.reshape(b.shape)


def _available() -> list[str]:
    if _pardiso_problem is None:
        try:
            _pypardiso()
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
    except (SingularMatrixError, InputError):
        raise
    except Exception as err:  # e.g. OSError: MKL's libraries do not load on this machine
        if _pardiso_worked:
            raise
        _fall_back(f"PARDISO failed: {type(err).__name__}: {err}")
        return _SuperLU(H)
