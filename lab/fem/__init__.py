"""Stage 2-4 of the pipeline: body and material -> energy with actuators -> static solve.

The concepts, one folder each, so a new one has an obvious home:

- :mod:`.bodies`: the body the FEM deforms (:class:`Body`: tet mesh, clamped nodes,
  markers); the description's structured cylinder is :class:`CylinderBody`.
- :mod:`.materials`: the material law (:class:`MaterialLaw`), neo-Hookean
  (:class:`NeoHookean`) or compressible foam (:class:`Hyperfoam`).
- :mod:`.actuators`: what drives the body (:class:`Actuator`), e.g. the description's
  angle-controlled cables (:class:`CableActuator`); an actuator may ask the statics for a
  :class:`Condensation`.
- :mod:`.model`: :class:`ArmFEM`, the assembled energy E(x, u) of body, material, gravity
  and actuators, with its exact derivatives.
- :mod:`.solve`: the equilibrium x(u) = argmin_x E(x, u) and dx/du (:func:`solve_static`,
  :func:`sensitivities`), warm-started walks (:class:`WalkPredictor`) and the FEM of
  as-built parameters theta with dx/dtheta (:class:`ParametrisedFEM`).

A new body, law or actuator is one module in its folder plus its registration
(:func:`register_body`, :func:`register_material`, :func:`register_actuator`).
"""

from lab.fem.actuators import (
    ACTUATORS,
    Actuator,
    CableActuator,
    CableRoute,
    Condensation,
    register_actuator,
    spring,
)
from lab.fem.bodies import (
    BODIES,
    Body,
    CylinderBody,
    FreeCoordinates,
    Marker,
    MeshSpec,
    TetMesh,
    barycentric,
    cylinder_mesh,
    load_mesh,
    register_body,
    save_mesh,
)
from lab.fem.materials import (
    MATERIALS,
    Hyperfoam,
    HyperfoamMaterial,
    InvertedElementError,
    Material,
    MaterialLaw,
    NeoHookean,
    NeoHookeanMaterial,
    hyperfoam_matching,
    lame,
    register_material,
)
from lab.fem.model import ArmFEM
from lab.fem.solve import (
    ParameterError,
    ParameterLayout,
    ParametrisedFEM,
    SingularMatrixError,
    StaticSolution,
    StaticSolveError,
    WalkPredictor,
    as_built_description,
    default_backend,
    factorize,
    sensitivities,
    solve_static,
)

__all__ = [
    "Body",
    "CylinderBody",
    "FreeCoordinates",
    "Marker",
    "BODIES",
    "register_body",
    "TetMesh",
    "MeshSpec",
    "cylinder_mesh",
    "load_mesh",
    "save_mesh",
    "barycentric",
    "MaterialLaw",
    "Material",
    "MATERIALS",
    "register_material",
    "lame",
    "NeoHookean",
    "NeoHookeanMaterial",
    "InvertedElementError",
    "Hyperfoam",
    "HyperfoamMaterial",
    "hyperfoam_matching",
    "Actuator",
    "Condensation",
    "ACTUATORS",
    "register_actuator",
    "CableActuator",
    "CableRoute",
    "spring",
    "ArmFEM",
    "SingularMatrixError",
    "default_backend",
    "factorize",
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
