"""Compiled element kernels: the material laws' energy, gradient and Hessian assembly in numba.

:func:`compiled_law` gives a law's element sums by the kernels (:mod:`lab.fem.kernels.laws` over
the loops of :mod:`lab.fem.kernels.neo_hookean` and :mod:`lab.fem.kernels.elements`, the foam
law's eigen-decomposition in :mod:`lab.fem.kernels.foam`), or None when
the NumPy reference assembly is chosen (:func:`set_assembly`, :func:`use_assembly`) or the
law has no kernel; :class:`lab.fem.model.ArmFEM` uses them for its energy, gradient and
Hessian, which it then scatters straight into the CSR data. Importing this package does not
import numba (:mod:`lab.fem.kernels.backend`); the first compiled assembly does.
"""

from lab.fem.kernels.backend import (
    COMPILED_MIN_TETS,
    KernelFallbackWarning,
    assembly_backend,
    set_assembly,
    use_assembly,
)

__all__ = [
    "COMPILED_MIN_TETS",
    "KernelFallbackWarning",
    "assembly_backend",
    "set_assembly",
    "use_assembly",
]


def compiled_law(law):
    """``law``'s element sums by the compiled kernels, if they are in use and know it.

    Parameters
    ----------
    law : MaterialLaw
        A law on a mesh (:mod:`lab.fem.materials`).

    Returns
    -------
    CompiledLaw or None
        :class:`lab.fem.kernels.laws.CompiledLaw` (numba imported), or None under the NumPy
        assembly (:func:`assembly_backend` of the law's tets) or for a law without kernels (a
        neo-Hookean, Yeoh or hyperfoam law has them).
    """
    if assembly_backend(len(law.V)) != "compiled":
        return None
    from lab.fem.kernels.laws import CompiledLaw, law_parameters

    return CompiledLaw(law) if law_parameters(law) is not None else None
