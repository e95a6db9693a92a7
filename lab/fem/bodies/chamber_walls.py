"""A chamber's cavity wall as a closed, oriented triangle surface, from a body's node group.

A body with chambers names the nodes of each cavity's wall: a :class:`ChamberedBody` by
chamber name, a :class:`MeshBody` by the physical surface of its file (the chamber's
``surface_group``). :func:`chamber_surface` takes the boundary triangles of the mesh whose
three nodes all lie in the group and orients them away from their tets, into the cavity
(:func:`~lab.fem.actuators.chamber_surfaces.oriented_surface`), as the pressure actuator
expects; it refuses a group the body lacks or a surface that is not closed.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.fem.actuators.chamber_surfaces import oriented_surface

__all__ = ["chamber_surface"]


def chamber_surface(body, group: str, name: str) -> np.ndarray:
    """The closed surface of a chamber's cavity: boundary triangles on a node group.

    Parameters
    ----------
    body : Body
        A body with ``groups`` (name -> node indices), e.g. :class:`ChamberedBody` or
        :class:`MeshBody`.
    group : str
        The group of the cavity's wall (a chambered body's chamber name, a mesh body's
        ``surface_group``).
    name : str
        The chamber's name, for the errors.

    Returns
    -------
    ndarray of int, shape (T, 3)
        The triangles, wound with normals into the cavity (InputError naming the chamber
        and the group if the body has no such group or its triangles do not close).
    """
    groups = getattr(body, "groups", None) or {}
    if group not in groups:
        raise InputError(
            f"chamber {name!r}: the body has no node group {group!r} for its cavity's wall; its groups are "
            f"{sorted(groups) or 'none'}"
        )
    on = np.zeros(body.mesh.n_nodes, bool)
    on[np.asarray(groups[group], np.int64)] = True
    faces = body.mesh.surface_triangles()
    tri = faces[on[faces].all(axis=1)]
    if len(tri) < 4:
        raise InputError(
            f"chamber {name!r}: group {group!r} holds {len(tri)} boundary triangles of the mesh, not a closed "
            "cavity surface"
        )
    try:
        return oriented_surface(body.mesh, tri, name)
    except InputError as exc:
        raise InputError(f"{exc} (the boundary triangles on group {group!r})") from None
