"""Stage 2-4 of the pipeline: mesh -> energy -> static solve.

A tetrahedral mesh of the arm (:mod:`.mesh`), the neo-Hookean elastic energy
(:mod:`.elasticity`, or the compressible foam law of :mod:`.hyperfoam`) and the one-sided
cable springs through via points (:mod:`.cables`) add up to the total energy ``E(x, u)``
of :class:`ArmFEM` (:mod:`.energy`). Its static equilibrium ``x(u) = argmin_x E(x, u)``
and the sensitivity ``dx/du`` come from :func:`solve_static` / :func:`sensitivities`
(:mod:`.statics`, Newton steps in :mod:`.steps`, sparse factorisations in
:mod:`.linsolve`); :class:`WalkPredictor`
(:mod:`.warmstart`) warm-starts a walk of neighbouring solves. :class:`ParametrisedFEM`
(:mod:`.parameters`) is the FEM as a function of as-built parameters theta (softness,
stiffness gradient, eyelet shifts, slack), with dx/dtheta from the same exact Hessian.
"""

from lab.fem.cables import CableRoute, CableSet, spring
from lab.fem.elasticity import InvertedElementError, NeoHookean, lame, project_psd
from lab.fem.energy import ArmFEM
from lab.fem.hyperfoam import Hyperfoam, HyperfoamMaterial, hyperfoam_law, hyperfoam_matching
from lab.fem.linsolve import SingularMatrixError, default_backend, factorize
from lab.fem.mesh import TetMesh, barycentric, cylinder_mesh, load_mesh, robot_mesh, save_mesh
from lab.fem.mesh_spec import MeshSpec
from lab.fem.parameters import ParameterError, ParameterLayout, ParametrisedFEM, as_built_description
from lab.fem.statics import (
    StaticSolution,
    StaticSolveError,
    sensitivities,
    solve_static,
)
from lab.fem.steps import (
    Factorised,
    condensed_step,
    newton_step,
    reused_sensitivity,
    secant_step,
    shifted_step,
)
from lab.fem.warmstart import WalkPredictor

__all__ = [
    "TetMesh",
    "MeshSpec",
    "cylinder_mesh",
    "robot_mesh",
    "load_mesh",
    "save_mesh",
    "barycentric",
    "lame",
    "NeoHookean",
    "InvertedElementError",
    "project_psd",
    "Hyperfoam",
    "HyperfoamMaterial",
    "hyperfoam_law",
    "hyperfoam_matching",
    "CableRoute",
    "spring",
    "CableSet",
    "ArmFEM",
    "SingularMatrixError",
    "default_backend",
    "factorize",
    "Factorised",
    "newton_step",
    "shifted_step",
    "secant_step",
    "condensed_step",
    "reused_sensitivity",
    "StaticSolveError",
    "StaticSolution",
    "solve_static",
    "sensitivities",
    "WalkPredictor",
    "ParameterError",
    "ParameterLayout",
    "ParametrisedFEM",
    "as_built_description",
]
