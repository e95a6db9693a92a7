"""The body interface: a tet mesh, its clamped nodes and the body points a rig observes.

A :class:`Body` is what the FEM deforms. It gives the rest mesh (:class:`TetMesh`), which
nodes are clamped (removed from the unknowns), and its markers: named points embedded in
the mesh with barycentric weights, so each is linear in the node positions. It also
embeds other points (e.g. a cable's eyelets), naming the one that lies outside.

:class:`FreeCoordinates` maps the mesh's degrees of freedom (3N,) to the stacked free
coordinates q (n_free,) that the solver works on; actuators use it to scatter their
forces. A new body is one module with a :class:`Body` subclass plus
:func:`register_body`; :data:`BODIES` lists them by name.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from lab.fem.bodies.mesh import TetMesh

#: Registered bodies, name -> class (see :func:`register_body`).
BODIES: dict[str, type] = {}


def register_body(name: str):
    """Class decorator registering a :class:`Body` subclass under ``name``.

    Parameters
    ----------
    name : str
        The key in :data:`BODIES`.

    Returns
    -------
    callable
        The decorator; it sets ``cls.kind = name`` and returns the class unchanged.
    """

    def decorate(cls):
        cls.kind = name
        BODIES[name] = cls
        return cls

    return decorate


@dataclass(frozen=True)
class Marker:
    """A body point, linear in the node positions: its position is ``weights @ x_W[nodes]`` (m).

    A point inside the body has the four nodes of the tet holding it and its barycentric
    weights (non-negative). A point on a stalk outside the body (:mod:`lab.fem.bodies.markers`) has the K
    nodes of the neighbourhood whose affine motion it follows, with least-squares weights,
    some negative. Either way the weights sum to 1, so a rigid motion of the nodes moves
    the point rigidly.

    Attributes
    ----------
    nodes : ndarray of int, shape (K,)
        The nodes the point depends on (K = 4 inside the body, K >= 16 on a stalk).
    weights : ndarray, shape (K,)
        Their weights, summing to 1.
    """

    nodes: np.ndarray
    weights: np.ndarray

    def position(self, x_W: np.ndarray) -> np.ndarray:
        """The marker's position.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions in frame W, m.

        Returns
        -------
        ndarray, shape (3,)
            The marker's position in frame W, m.
        """
        return self.weights @ x_W[self.nodes]


class Body(ABC):
    """A deformable body: ``mesh`` (:class:`TetMesh`), ``clamped`` (N,) bool (nodes held at
    rest) and :meth:`markers`. Subclasses set both attributes in ``__init__``."""

    kind: str = ""
    mesh: TetMesh
    clamped: np.ndarray

    @abstractmethod
    def embed(self, points_W, what: str) -> tuple[np.ndarray, np.ndarray]:
        """Embed points in the rest mesh.

        Parameters
        ----------
        points_W : array_like, shape (P, 3) or (3,)
            Points in frame W, m.
        what : str
            What the points are, for the error naming one outside the body.

        Returns
        -------
        nodes : ndarray, shape (P, 4)
            The nodes of each point's tet.
        weights : ndarray, shape (P, 4)
            Barycentric weights (non-negative, summing to 1).
        """

    @abstractmethod
    def markers(self) -> dict[str, Marker]:
        """The observed body points.

        Returns
        -------
        dict of str to Marker
            Markers by name; ``"tip"`` is the one :meth:`lab.fem.ArmFEM.tip` reports.
        """


@dataclass(frozen=True)
class FreeCoordinates:
    """The unknowns of a body: the free coordinates q (n_free,) among the ravelled node
    positions x_W (3N,) (m), every coordinate of every unclamped node.

    Attributes
    ----------
    free_dofs : ndarray of int, shape (n_free,)
        Indices of the free coordinates in the ravelled node positions (3N,).
    dof_to_free : ndarray of int, shape (3N,)
        The inverse map: the index in q of each coordinate, -1 where clamped.
    """

    free_dofs: np.ndarray
    dof_to_free: np.ndarray

    @classmethod
    def of(cls, body: Body) -> FreeCoordinates:
        """The free coordinates of ``body``: every coordinate of every unclamped node.

        Parameters
        ----------
        body : Body
            The body.

        Returns
        -------
        FreeCoordinates
            Its free coordinates.
        """
        free_dofs = np.flatnonzero(np.repeat(~body.clamped, 3))
        dof_to_free = np.full(3 * body.mesh.n_nodes, -1)
        dof_to_free[free_dofs] = np.arange(len(free_dofs))
        return cls(free_dofs, dof_to_free)

    @property
    def n_free(self) -> int:
        """Number of free coordinates."""
        return len(self.free_dofs)

    def point_matrix(self, marker: Marker) -> sp.csr_matrix:
        """S (3, n_free) with ``marker.position(x) = S q + const``.

        Parameters
        ----------
        marker : Marker
            An embedded point.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (3, n_free)
            The point's position as a linear map of the free coordinates (m per m).
        """
        rows, cols, vals = [], [], []
        for n, w in zip(marker.nodes, marker.weights):
            for d in range(3):
                if self.dof_to_free[3 * n + d] >= 0:
                    rows.append(d), cols.append(self.dof_to_free[3 * n + d]), vals.append(w)
        return sp.csr_matrix((vals, (rows, cols)), shape=(3, self.n_free))
