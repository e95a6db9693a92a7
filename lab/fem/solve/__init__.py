"""The solve: static equilibrium, its sensitivities and warm-started walks.

:func:`solve_static` / :func:`sensitivities` (:mod:`.statics`, Newton steps in :mod:`.steps`,
sparse factorisations in :mod:`.linsolve`) give x(u) = argmin_x E(x, u) and dx/du;
:class:`WalkPredictor` (:mod:`.warmstart`) warm-starts a walk of neighbouring solves;
:class:`ParametrisedFEM` (:mod:`.parameters`) gives the FEM of as-built parameters theta and
dx/dtheta, theta laid out by :class:`ParameterLayout` (:mod:`.parameter_layout`). They use
the model only through its generic interface (:class:`lab.fem.model.ArmFEM`: energy,
gradient, Hessian, mixed derivative, the actuators'
:class:`~lab.fem.actuators.Condensation`).
"""

from lab.fem.solve.linsolve import SingularMatrixError, default_backend, factorize
from lab.fem.solve.parameter_layout import ParameterError, ParameterLayout
from lab.fem.solve.parameters import ParametrisedFEM, as_built_description
from lab.fem.solve.statics import StaticSolution, StaticSolveError, sensitivities, solve_static
from lab.fem.solve.warmstart import WalkPredictor

__all__ = [
    "SingularMatrixError",
    "default_backend",
    "factorize",
    "ParameterError",
    "ParameterLayout",
    "ParametrisedFEM",
    "as_built_description",
    "StaticSolution",
    "StaticSolveError",
    "sensitivities",
    "solve_static",
    "WalkPredictor",
]
