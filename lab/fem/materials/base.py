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
    each of node positions ``x_W`` (N, 3) m.

    Attributes
    ----------
    V : ndarray, shape (M,)
        Rest volume of each tet, m^3.
    """

    V: np.ndarray

    def energy(self, x_W: np.ndarray) -> float:
        """The elastic energy.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        float
            Energy, J (+inf if an element is inverted).
        """

    def energy_and_gradient(self, x_W: np.ndarray) -> tuple[float, np.ndarray]:
        """Energy and nodal gradient, sharing the kinematics.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        energy : float
            J (+inf if an element is inverted).
        gradient : ndarray, shape (N, 3) or None
            dE/dx, N (None if an element is inverted).
        """

    def nodal_gradient(self, x_W: np.ndarray) -> np.ndarray:
        """The elastic forces' negative, summed at the nodes.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (N, 3)
            dE/dx, N.
        """

    def gradient(self, x_W: np.ndarray) -> np.ndarray:
        """Per-element gradients (the elastic force of each tet on its nodes, negated).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (M, 4, 3)
            dE_t/dx of each tet's four nodes, N.
        """

    def hessian(self, x_W: np.ndarray) -> np.ndarray:
        """Exact element Hessians.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (M, 12, 12)
            d2E_t/dx2 per tet, N/m, dofs ravelled x, y, z per node.
        """

    def hessian_product(self, x_W: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """Exact Hessian products at ``x_W``, without the element Hessians.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        callable
            dx (N, 3) m -> d2E/dx2 dx (N, 3) N.
        """


@runtime_checkable
class Material(Protocol):
    """The parameters of a law, without a mesh; a dataclass of them (e.g.
    :class:`~lab.fem.materials.neo_hookean.NeoHookeanMaterial`).

    Attributes
    ----------
    *fields
        The law's parameters, in SI units (Pa for moduli), scalar or one per tet (M,).
    """

    def on_mesh(self, mesh) -> MaterialLaw:
        """The law on ``mesh``'s elements.

        Parameters
        ----------
        mesh : TetMesh
            The rest mesh (m, frame W).

        Returns
        -------
        MaterialLaw
            The law on its M tets.
        """
