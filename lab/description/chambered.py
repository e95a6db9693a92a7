"""A cylinder or tapered body with fluid chambers: the solid less its cavities, meshed by gmsh.

:func:`chambered_body_mesh` builds the body with gmsh's OpenCASCADE kernel -- a cylinder,
or the solid of revolution of a tapered profile (one cone per profile segment, fused into
one volume) -- cuts out each chamber's cavity (a cylinder parallel to the x axis, see
:class:`~lab.description.chambers.Chamber`) and meshes the rest with linear tetrahedra of
the target size, on one thread so the same inputs give the same mesh bit for bit. The
result is checked like a body file (:mod:`lab.description.geometry`: oriented, connected,
no degenerate tet) and carries named node groups: ``"base"``, the nodes on the face x = 0,
and one group per chamber, the nodes on its cavity's wall. Each surface of the cut is
given to the chamber whose cavity it lies on, node by node within 1e-6 of the body's
extent, so chambers at any angle and in several axial segments are told apart.

The mesh is cached as ``.npz`` under :func:`~lab.description.geometry.mesh_cache_dir`,
keyed by the SHA-256 of the profile, the chambers' geometry, the size, gmsh's version and
:data:`CACHE_FORMAT`.
"""

from __future__ import annotations

import hashlib
import json
import math

import numpy as np

from lab.description.geometry import (
    MAX_GEOMETRY_TETS,
    BodyMesh,
    MeshFileError,
    _checked,
    _load_cached,
    _save_cached,
    mesh_cache_dir,
)

__all__ = ["CACHE_FORMAT", "body_profile", "chambered_body_mesh"]

#: Version of the cached arrays; bump it when meshing or checking changes the result.
CACHE_FORMAT = 1
#: A node lies on a cavity's wall (or the base) within this fraction of the body's extent.
ON_SURFACE = 1e-6


def body_profile(shape: str, length_m: float, radius_m: float, profile_m=None) -> np.ndarray:
    """The stations [x, r] of a cylinder or tapered body's outline.

    Parameters
    ----------
    shape : str
        ``"cylinder"`` or ``"tapered"``.
    length_m, radius_m : float
        A cylinder's length and radius, m.
    profile_m : array_like, shape (S, 2), optional
        A tapered body's stations [x, r], m (x from 0, increasing; r > 0).

    Returns
    -------
    ndarray, shape (S, 2)
        The stations, m (two for a cylinder).
    """
    if shape == "cylinder":
        return np.array([[0.0, float(length_m)], [float(radius_m)] * 2]).T
    if shape != "tapered":
        raise MeshFileError(f"chambers: a body with geometric chambers is a cylinder or tapered, not {shape!r}")
    profile = np.asarray(profile_m, float)
    if profile.ndim != 2 or profile.shape[1] != 2 or len(profile) < 2:
        raise MeshFileError(f"chambers: a tapered profile is at least two [x_m, r_m] stations, got {profile.shape}")
    if profile[0, 0] != 0 or np.any(np.diff(profile[:, 0]) <= 0) or np.any(profile[:, 1] <= 0):
        raise MeshFileError(f"chambers: a profile starts at x = 0, increases and has radii > 0: {profile.tolist()}")
    return profile


def _geometry(chamber) -> list[float]:
    return [float(getattr(chamber, k)) for k in ("angle_deg", "offset_m", "radius_m", "start_m", "end_m")]


def _cache_key(profile: np.ndarray, chambers, size_m: float) -> str:
    import gmsh

    settings = {
        "profile_m": profile.tolist(),
        "chambers": [[c.name, *_geometry(c)] for c in chambers],
        "size_m": float(size_m),
        "gmsh": gmsh.__version__,
        "format": CACHE_FORMAT,
    }
    return hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()


def _names(chambers) -> str:
    return ", ".join(repr(c.name) for c in chambers)


def chambered_body_mesh(shape, length_m: float, radius_m: float, chambers, size_m: float) -> BodyMesh:
    """Mesh a cylinder or tapered body less its chambers' cavities (cached).

    Parameters
    ----------
    shape : BodyShape or str
        The body's shape (``.shape`` ``"cylinder"`` or ``"tapered"``, a tapered body's
        ``.profile_m`` (S, 2) stations [x, r] in m), or just ``"cylinder"``.
    length_m, radius_m : float
        A cylinder's length and radius, m (a tapered body's come from its profile).
    chambers : sequence of Chamber
        The cavities: ``angle_deg`` (deg about +x), ``offset_m``, ``radius_m``, ``start_m``,
        ``end_m`` (m), and distinct names (not ``"base"``).
    size_m : float
        The target element size, m (gmsh's largest and smallest).

    Returns
    -------
    BodyMesh
        Nodes (N, 3) m, positively oriented tets (M, 4), groups ``"base"`` and one per
        chamber (node indices). MeshFileError naming the chambers when the size would make
        over ``MAX_GEOMETRY_TETS`` tets or gmsh fails, and
        naming the chamber whose cavity has no wall in the mesh.
    """
    kind = getattr(shape, "shape", shape)
    profile = body_profile(kind, length_m, radius_m, getattr(shape, "profile_m", None))
    chambers = tuple(chambers)
    names = [c.name for c in chambers]
    if not chambers:
        raise MeshFileError("chambers: a chambered body needs at least one chamber")
    if len(set(names)) != len(names) or "base" in names:
        raise MeshFileError(f"chambers: names {names} must be distinct and not 'base' (the base face's group)")
    missing = [c.name for c in chambers if any(getattr(c, k) is None for k in ("angle_deg", "radius_m", "end_m"))]
    if missing:
        raise MeshFileError(f"chambers {missing}: a cylinder or tapered body's chamber needs its cavity's geometry")
    if not (size_m is not None and math.isfinite(size_m) and size_m > 0):
        raise MeshFileError(
            f"mesh.size_m: a body with chambers is meshed by gmsh and needs [mesh] size_m, got {size_m}"
        )
    length, r_max = float(profile[-1, 0]), float(profile[:, 1].max())
    estimate = 6.0 * math.pi * r_max**2 * length / size_m**3  # about 6 tets per cube of the size
    if estimate > MAX_GEOMETRY_TETS:
        raise MeshFileError(
            f"mesh.size_m: {size_m:g} m elements on a body of length {length:g} m and radius {r_max:g} m would make "
            f"about {estimate:.2g} tets (at most {MAX_GEOMETRY_TETS:.0e}); use a larger size_m"
        )
    cached = mesh_cache_dir() / f"{_cache_key(profile, chambers, size_m)}.npz"
    mesh = _load_cached(cached)
    if mesh is not None:
        return mesh
    X, tets, groups = _mesh(profile, chambers, size_m)
    where = f"{kind} body with chambers {_names(chambers)}"
    mesh = _checked(X, tets, groups, f"size_m = {size_m:g} m", "chambers", "m")
    empty = [n for n in names if len(mesh.groups[n]) == 0]
    if empty:
        raise MeshFileError(f"chambers {empty}: no wall of the cavity in the mesh of the {where}")
    _save_cached(cached, mesh)
    return mesh


def _mesh(profile: np.ndarray, chambers, size_m: float):
    """gmsh: the solid of revolution less the cavities, linear tets; nodes, tets, groups."""
    import gmsh

    gmsh.initialize(["-nt", "1"], readConfigFiles=False, interruptible=False)
    try:
        for option, value in (
            ("General.Terminal", 0),
            ("General.NumThreads", 1),
            ("Mesh.MaxNumThreads3D", 1),
            ("Mesh.RandomSeed", 1),
            ("Mesh.MeshSizeMax", size_m),
            ("Mesh.MeshSizeMin", size_m),
            ("Mesh.ElementOrder", 1),
            ("Mesh.Optimize", 1),
        ):
            gmsh.option.setNumber(option, value)
        gmsh.model.add("chambered")
        occ = gmsh.model.occ
        try:
            solid = _solid(occ, profile)
            tools = []
            for c in chambers:
                angle = math.radians(c.angle_deg)
                y, z = c.offset_m * math.cos(angle), c.offset_m * math.sin(angle)
                tools.append((3, occ.addCylinder(c.start_m, y, z, c.end_m - c.start_m, 0, 0, c.radius_m)))
            body, _ = occ.cut(solid, tools)
            occ.synchronize()
            if len([t for d, t in body if d == 3]) != 1:
                raise MeshFileError(
                    f"chambers {_names(chambers)}: the body less its cavities is {len(body)} pieces, not one volume"
                )
            gmsh.model.mesh.generate(3)
        except MeshFileError:
            raise
        except Exception as exc:
            raise MeshFileError(f"chambers {_names(chambers)}: gmsh could not mesh the body: {exc}") from None
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, tet_nodes = gmsh.model.mesh.getElementsByType(4)
        if len(tet_nodes) == 0:
            raise MeshFileError(f"chambers {_names(chambers)}: gmsh made no tetrahedra")
        index = np.full(int(tags.max()) + 1, -1, np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        X = np.asarray(coords, float).reshape(-1, 3)
        tets = index[np.asarray(tet_nodes, np.int64)].reshape(-1, 4)
        tol = ON_SURFACE * float(max(profile[-1, 0], 2 * profile[:, 1].max()))
        groups = {"base": np.flatnonzero(X[:, 0] <= tol)}
        walls = {c.name: [] for c in chambers}
        for _, tag in gmsh.model.getEntities(2):
            nodes, _, _ = gmsh.model.mesh.getNodes(2, tag, includeBoundary=True)
            nodes = index[np.asarray(nodes, np.int64)]
            for c in chambers:
                if len(nodes) and np.all(_on_wall(X[nodes], c, tol)):
                    walls[c.name].append(nodes)
                    break
        for name, pieces in walls.items():
            groups[name] = np.unique(np.concatenate(pieces)) if pieces else np.zeros(0, np.int64)
        return X, tets, groups
    finally:
        gmsh.finalize()


def _solid(occ, profile: np.ndarray) -> list:
    """The solid of revolution about +x of the profile: a cylinder, or fused cones."""
    if len(profile) == 2 and profile[0, 1] == profile[1, 1]:
        return [(3, occ.addCylinder(0, 0, 0, profile[1, 0], 0, 0, profile[0, 1]))]
    cones = [(3, occ.addCone(x0, 0, 0, x1 - x0, 0, 0, r0, r1)) for (x0, r0), (x1, r1) in zip(profile[:-1], profile[1:])]
    if len(cones) == 1:
        return cones
    fused, _ = occ.fuse(cones[:1], cones[1:])
    return fused


def _on_wall(P: np.ndarray, chamber, tol: float) -> np.ndarray:
    """Whether points (P, 3) m lie on a cavity's wall: its side or one of its end disks."""
    angle = math.radians(chamber.angle_deg)
    centre = chamber.offset_m * np.array([math.cos(angle), math.sin(angle)])
    rho = np.linalg.norm(P[:, 1:] - centre, axis=1)
    x = P[:, 0]
    within = (x >= chamber.start_m - tol) & (x <= chamber.end_m + tol)
    side = np.abs(rho - chamber.radius_m) <= tol
    ends = (np.abs(x - chamber.start_m) <= tol) | (np.abs(x - chamber.end_m) <= tol)
    return within & (side | (ends & (rho <= chamber.radius_m + tol)))
