"""Stage 2-4 of the pipeline: body and material -> energy with actuators -> static solve.

The concepts, one folder each, so a new one has an obvious home:

- :mod:`.bodies`: the body the FEM deforms (:class:`Body`: tet mesh, clamped nodes,
  markers); the description's body is :func:`body_of`'s: :class:`CylinderBody`,
  :class:`TaperedBody`, :class:`ChamberedBody` or :class:`MeshBody`.
- :mod:`.materials`: the material law (:class:`MaterialLaw`), neo-Hookean
  (:class:`NeoHookean`), compressible foam (:class:`Hyperfoam`) or silicone (:class:`Yeoh`).
- :mod:`.actuators`: what drives the body (:class:`Actuator`), e.g. the description's
  angle-controlled cables (:class:`CableActuator`); an actuator may ask the statics for a
  :class:`Condensation`.
- :mod:`.model`: :class:`ArmFEM`, the assembled energy E(x, u) of body, material, gravity
  and actuators, with its exact derivatives; its element sums run as compiled kernels
  (:mod:`.kernels`) or, the reference, in NumPy (:func:`set_assembly`, :func:`use_assembly`).
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
    PressureChamberActuator,
    VolumeChamberActuator,
    cavity_surfaces,
    register_actuator,
    spring,
)
from lab.fem.bodies import (
    BODIES,
    Body,
    ChamberedBody,
    CylinderBody,
    FreeCoordinates,
    Marker,
    MeshBody,
    MeshSpec,
    TaperedBody,
    TetMesh,
    barycentric,
    body_of,
    chamber_surface,
    cylinder_mesh,
    load_mesh,
    register_body,
    save_mesh,
    tapered_mesh,
)
from lab.fem.kernels import COMPILED_MIN_TETS, KernelFallbackWarning, assembly_backend, set_assembly, use_assembly
from lab.fem.materials import (
    MATERIALS,
    Hyperfoam,
    HyperfoamMaterial,
    InvertedElementError,
    Material,
    MaterialLaw,
    NeoHookean,
    NeoHookeanMaterial,
    Yeoh,
    YeohMaterial,
    hyperfoam_matching,
    lame,
    register_material,
    yeoh_matching,
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
    "ACTUATORS",
    "COMPILED_MIN_TETS",
    "BODIES",
    "MATERIALS",
    "Actuator",
    "ArmFEM",
    "Body",
    "CableActuator",
    "CableRoute",
    "ChamberedBody",
    "Condensation",
    "CylinderBody",
    "FreeCoordinates",
    "Hyperfoam",
    "HyperfoamMaterial",
    "InvertedElementError",
    "KernelFallbackWarning",
    "Marker",
    "Material",
    "MaterialLaw",
    "MeshBody",
    "MeshSpec",
    "NeoHookean",
    "NeoHookeanMaterial",
    "ParameterError",
    "ParameterLayout",
    "ParametrisedFEM",
    "PressureChamberActuator",
    "SingularMatrixError",
    "StaticSolution",
    "StaticSolveError",
    "TaperedBody",
    "TetMesh",
    "VolumeChamberActuator",
    "WalkPredictor",
    "Yeoh",
    "YeohMaterial",
    "as_built_description",
    "assembly_backend",
    "barycentric",
    "body_of",
    "chamber_surface",
    "cavity_surfaces",
    "cylinder_mesh",
    "default_backend",
    "factorize",
    "hyperfoam_matching",
    "lame",
    "load_mesh",
    "register_actuator",
    "register_body",
    "register_material",
    "save_mesh",
    "sensitivities",
    "set_assembly",
    "solve_static",
    "spring",
    "tapered_mesh",
    "use_assembly",
    "yeoh_matching",
]
