"""The material-law interface: elastic energy of a mesh's elements and its derivatives.

A material has two parts. The *material* (:class:`Material`) is the law's parameters
without a mesh; :meth:`Material.on_mesh` places it on a mesh's tetrahedra, giving the
*law* (:class:`MaterialLaw`): the elastic energy of node positions x_W (N, 3) m and its
exact derivatives, with +inf energy when an element is inverted. Every law in this package
(:class:`~lab.fem.materials.neo_hookean.NeoHookean`,
:class:`~lab.fem.materials.hyperfoam.Hyperfoam`) has exactly this interface and is the only
one the FEM uses. A new law is one module with a material class decorated with
:func:`register_material`; :data:`MATERIALS` lists them by name.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol, runtime_checkable

import numpy as np

#: Registered materials, name -> class (see :func:`register_material`).
MATERIALS: dict[str, type] = {}


def register_material(name: str):
    """Class decorator registering a :class:`Material` class under ``name``.

    Parameters
    ----------
    name : str
        The key in :data:`MATERIALS`.

    Returns
    -------
    callable
        The decorator; it returns the class unchanged.
    """

    def decorate(cls):
        MATERIALS[name] = cls
        return cls

    return decorate


@runtime_checkable
class MaterialLaw(Protocol):
    """A law on a mesh's M elements: rest volumes ``V`` (M,) m^3 and the methods below,
    each of node positions ``x_W`` (N, 3) m."""

    V: np.ndarray

    def energy(self, x_W: np.ndarray) -> float:
        """Elastic energy in J (+inf if an element is inverted)."""

    def energy_and_gradient(self, x_W: np.ndarray) -> tuple[float, np.ndarray]:
        """Energy (J) and nodal gradient dE/dx (N, 3) in N, sharing the kinematics."""

    def nodal_gradient(self, x_W: np.ndarray) -> np.ndarray:
        """dE/dx (N, 3) in N."""

    def gradient(self, x_W: np.ndarray) -> np.ndarray:
        """Per-element gradients (M, 4, 3) in N (the elastic force of each tet)."""

    def hessian(self, x_W: np.ndarray) -> np.ndarray:
        """Exact element Hessians (M, 12, 12) in N/m, dofs ravelled x, y, z per node."""

    def hessian_product(self, x_W: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """A function dx (N, 3) m -> d2E/dx2 dx (N, 3) N at ``x_W``."""


@runtime_checkable
class Material(Protocol):
    """The parameters of a law, without a mesh."""

    def on_mesh(self, mesh) -> MaterialLaw:
        """The law on ``mesh``'s elements (a :class:`~lab.fem.bodies.mesh.TetMesh`)."""
