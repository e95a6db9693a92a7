"""Which assembly the FEM uses -- compiled kernels or the NumPy reference -- and how they compile.

``"compiled"`` (the default where numba imports, for meshes of at least
:data:`COMPILED_MIN_TETS` tets) runs the element sums of every material law
(energy, nodal gradient, element Hessians scattered straight into the Hessian's CSR data)
as numba kernels; ``"numpy"`` is the vectorised reference of :mod:`lab.fem.materials`, which
the tests compare the kernels against to round-off. :func:`set_assembly` and
:func:`use_assembly` choose one in-process.

numba is imported only when a model first assembles with the kernels, never by a command
that does not solve. The kernels are compiled once and kept in numba's on-disk cache
(``cache=True``): in a ``__pycache__`` folder beside this package, else numba's user-wide
cache folder, or ``NUMBA_CACHE_DIR`` if set. Where none is writable (a read-only install
with a read-only home), they are compiled in every process instead, with one
:class:`KernelFallbackWarning`; where numba does not import at all, the FEM uses the NumPy
assembly, with the same warning once per process (same results, slower).
"""

from __future__ import annotations

import contextlib
import warnings

from lab.errors import InputError

#: The assemblies, by name.
BACKENDS = ("compiled", "numpy")
#: By default a model of fewer tets keeps the NumPy assembly: loading numba and the kernels
#: costs ~0.4 s of CPU per process, which a solve on 432 tets repays after ~60 solves and one
#: on 108 tets after ~150 (benchmarks/bench_small_meshes.py), more than a short run makes.
COMPILED_MIN_TETS = 400

_choice: str | None = None  # None: "compiled" where numba imports
_numba_problem: str | None = None  # why numba cannot be used (None: not known to fail)
_warned: set = set()


class KernelFallbackWarning(RuntimeWarning):
    """The compiled kernels are unavailable (numba missing) or cannot be cached on disk."""


def _warn_once(key: str, message: str) -> None:
    if key not in _warned:
        _warned.add(key)
        warnings.warn(message, KernelFallbackWarning, stacklevel=4)


def set_assembly(name: str | None) -> str | None:
    """Choose the assembly for this process.

    Parameters
    ----------
    name : str or None
        ``"compiled"``, ``"numpy"``, or None for the default (compiled where numba imports).

    Returns
    -------
    str or None
        The previous choice (None: it was the default).
    """
    global _choice
    if name is not None and name not in BACKENDS:
        raise InputError(f"assembly {name!r}: choose one of {list(BACKENDS)}")
    previous, _choice = _choice, name
    return previous


@contextlib.contextmanager
def use_assembly(name: str | None):
    """A ``with`` block assembling with ``name`` (:func:`set_assembly`), the choice restored after.

    Parameters
    ----------
    name : str or None
        ``"compiled"``, ``"numpy"`` or None (the default).

    Returns
    -------
    contextlib.AbstractContextManager
        The block's context.
    """
    previous = set_assembly(name)
    try:
        yield
    finally:
        set_assembly(previous)


def assembly_backend(n_tets: int | None = None) -> str:
    """The assembly a model uses: the chosen one, else ``"compiled"`` where numba imports
    and the model has at least :data:`COMPILED_MIN_TETS` tets.

    Parameters
    ----------
    n_tets : int, optional
        The model's number of tets (None: a large model).

    Returns
    -------
    str
        ``"compiled"`` or ``"numpy"`` (``"numpy"`` where numba is missing, with one
        :class:`KernelFallbackWarning` per process, also when ``"compiled"`` was chosen).
    """
    global _numba_problem
    if _choice == "numpy" or (_choice is None and n_tets is not None and n_tets < COMPILED_MIN_TETS):
        return "numpy"
    if _numba_problem is None:
        try:
            import numba  # noqa: F401  (the kernels' modules import it again; this only probes)
        except Exception as err:  # ImportError, or a numba/llvmlite that fails to load
            _numba_problem = f"{type(err).__name__}: {err}"
    if _numba_problem is not None:
        _warn_once(
            "import",
            f"numba is unavailable ({_numba_problem}); the FEM assembles with NumPy instead (same results, "
            "slower). Install numba, or call lab.fem.kernels.set_assembly('numpy') to choose it and silence this.",
        )
        return "numpy"
    return "compiled"


def jit(fn=None, *, inline: bool = False):
    """``numba.njit`` with the on-disk cache, or without it where no cache folder is writable.

    Parameters
    ----------
    fn : callable
        A function numba can compile in nopython mode (``@jit`` or ``@jit(inline=True)``).
    inline : bool
        Inline it into its callers at numba's IR level (a small helper of a loop: no call,
        no reference counting of its array arguments per element).

    Returns
    -------
    numba.core.registry.CPUDispatcher
        The compiled function (lazily: compiled, or loaded from the cache, at its first call).
    """
    if fn is None:
        return lambda f: jit(f, inline=inline)
    import numba

    options = dict(nogil=True, error_model="numpy", inline="always" if inline else "never")
    try:
        return numba.njit(cache=True, **options)(fn)
    except RuntimeError as err:  # "cannot cache function ...: no locator available"
        _warn_once(
            "cache",
            f"numba cannot cache the FEM kernels ({err}); they are compiled in every process (seconds). "
            "Set NUMBA_CACHE_DIR to a writable folder to keep them.",
        )
        return numba.njit(cache=False, **options)(fn)
