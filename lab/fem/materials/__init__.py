"""Material laws: the elastic energy of the body's elements.

:class:`MaterialLaw` and :class:`Material` are the one interface (:mod:`.base`); the
compressible neo-Hookean law (:mod:`.neo_hookean`), the Storåkers/Ogden foam law
(:mod:`.hyperfoam`) and the Yeoh law for silicone (:mod:`.yeoh`, through the density-law
sums of :mod:`.density`) implement it, on the linear tetrahedra of :mod:`.elements`. A new
law is one module with a material class decorated with :func:`register_material`.
"""

from lab.fem.materials.base import MATERIALS, Material, MaterialLaw, register_material
from lab.fem.materials.elements import InvertedElementError
from lab.fem.materials.hyperfoam import Hyperfoam, HyperfoamMaterial, hyperfoam_matching
from lab.fem.materials.neo_hookean import NeoHookean, NeoHookeanMaterial, lame
from lab.fem.materials.yeoh import Yeoh, YeohMaterial, yeoh_matching

__all__ = [
    "MATERIALS",
    "Material",
    "MaterialLaw",
    "register_material",
    "Hyperfoam",
    "HyperfoamMaterial",
    "hyperfoam_matching",
    "InvertedElementError",
    "NeoHookean",
    "NeoHookeanMaterial",
    "lame",
    "Yeoh",
    "YeohMaterial",
    "yeoh_matching",
]
