"""A body given as a file: a tetrahedral mesh (meshio) or a CAD geometry (gmsh), read and checked.

:func:`read_body_mesh` turns the ``[body] shape = "mesh"`` of a description into a
:class:`BodyMesh` in metres: a tetrahedral mesh file is read with meshio (``.msh``, ``.vtu``,
``.vtk``, ``.mesh``, ``.inp``); a geometry (``.geo``, ``.step``/``.stp``, ``.brep``) is meshed
by gmsh with linear tetrahedra of the target size ``[mesh] size_m``. Every body is checked:
tetrahedra present, none degenerate, one orientation (a file wound the other way throughout
is reoriented), one connected piece, a plausible size for its unit. Nodes no tet uses are
dropped.

The result is cached as ``.npz`` under ``$LAB_CACHE_DIR/meshes`` (default
``~/.cache/lab/meshes``), keyed by the SHA-256 of the file's bytes, the settings (unit,
size, order), the cache format and gmsh's version, so a description always gives the same
mesh, bit for bit, and a second load is fast. A ``.geo`` that ``Merge``s or ``Include``s
other files is keyed by the ``.geo`` alone: edit the ``.geo`` (or clear the cache) when only
an included file changes.

:func:`clamped_nodes` says which nodes are held (the base or a named physical group) and
:func:`locate` finds the tet holding each of many points (:mod:`lab.description.tet_search`).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from lab.description.tet_search import locate
from lab.errors import InputError
from lab.files import atomic_open

__all__ = ["BodyMesh", "MeshFileError", "clamped_nodes", "file_sha256", "locate", "mesh_cache_dir", "read_body_mesh"]

#: Suffixes read by meshio (tetrahedral meshes) and meshed by gmsh (geometries).
MESH_SUFFIXES = (".msh", ".vtu", ".vtk", ".mesh", ".inp")
GEOMETRY_SUFFIXES = (".geo", ".step", ".stp", ".brep")
#: Scale of each ``mesh_unit`` to metres.
UNITS = {"m": 1.0, "mm": 1e-3}
#: A body's extent (m) outside this range is taken for a unit mistake.
PLAUSIBLE_EXTENT_M = (1e-3, 5.0)
#: The most tets a geometry may be meshed into (about 2 GB for the FEM; a smaller size_m is refused).
MAX_GEOMETRY_TETS = 2_000_000
#: A tet whose |volume| is below this fraction of the median is degenerate.
DEGENERATE_FRACTION = 1e-12
#: Version of the cached arrays; bump it when reading or checking changes the result
#: (2: a gmsh 2.2 ``.msh`` file's named physical groups kept).
CACHE_FORMAT = 2


class MeshFileError(InputError):
    """A body's mesh or geometry file is missing, unreadable or not a valid body."""


@dataclass(frozen=True)
class BodyMesh:
    """A checked body mesh at rest, in metres.

    Attributes
    ----------
    X_m : ndarray, shape (N, 3)
        Node positions (frame W at rest), m; every node is used by a tet.
    tets : ndarray of int64, shape (M, 4)
        Node indices of each tetrahedron, positively oriented.
    groups : dict
        Node indices (ndarray of int) of each named physical group of the file, by name
        (gmsh physical groups, meshio cell sets and point sets).
    """

    X_m: np.ndarray
    tets: np.ndarray
    groups: dict = field(default_factory=dict)


def _err(where: str, path, message: str) -> MeshFileError:
    return MeshFileError(f"field '{where}' ({path}): {message}")


def file_sha256(path, where: str = "body.mesh_file") -> str:
    """The SHA-256 of a file's bytes.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.
    where : str
        The field naming it, for the error.

    Returns
    -------
    str
        The hex digest (MeshFileError naming ``where`` and the path if it cannot be read).
    """
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError as exc:
        reason = "no such file" if not Path(path).exists() else (exc.strerror or str(exc))
        raise _err(where, path, f"cannot read the mesh file: {reason}") from None


def mesh_cache_dir() -> Path:
    """The folder of cached body meshes: ``$LAB_CACHE_DIR/meshes``, default ``~/.cache/lab/meshes``.

    Returns
    -------
    pathlib.Path
        The folder (not created here).
    """
    root = os.environ.get("LAB_CACHE_DIR")
    return (Path(root) if root else Path.home() / ".cache" / "lab") / "meshes"


def _cache_key(sha: str, shape, geometry: bool) -> str:
    settings = {"sha256": sha, "unit": shape.mesh_unit, "size_m": shape.mesh_size_m, "order": shape.mesh_order}
    settings["format"] = CACHE_FORMAT
    if geometry:
        import gmsh

        settings["gmsh"] = gmsh.__version__
    return hashlib.sha256(json.dumps(settings, sort_keys=True).encode()).hexdigest()


def _load_cached(path: Path) -> BodyMesh | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            groups = {k[len("group:") :]: z[k] for k in z.files if k.startswith("group:")}
            return BodyMesh(z["X_m"], z["tets"], groups)
    except (OSError, KeyError, ValueError):  # absent or damaged: read the file again
        return None


def _save_cached(path: Path, mesh: BodyMesh) -> None:
    buf = io.BytesIO()
    np.savez(buf, X_m=mesh.X_m, tets=mesh.tets, **{f"group:{k}": v for k, v in mesh.groups.items()})
    try:
        with atomic_open(path, "wb") as fh:
            fh.write(buf.getvalue())
    except OSError:  # a read-only cache only costs time
        pass


def read_body_mesh(shape, where: str = "body.mesh_file") -> BodyMesh:
    """Read (or mesh) and check the body file of a ``"mesh"`` :class:`~lab.description.BodyShape`.

    Parameters
    ----------
    shape : BodyShape
        Its ``mesh_file`` (path), ``mesh_unit`` ("m" or "mm"), ``mesh_size_m`` (target element
        size, m, geometry files only), ``mesh_order`` (1) and, if set, ``mesh_sha256`` (the
        file must still have this content).
    where : str
        The field naming the file in errors.

    Returns
    -------
    BodyMesh
        Nodes in m, positively oriented tets, physical groups; MeshFileError naming the
        field and the file for a missing, unreadable or invalid body.
    """
    path = Path(shape.mesh_file)
    suffix = path.suffix.lower()
    if shape.mesh_order != 1:
        raise _err("mesh.order", path, f"must be 1 (linear tetrahedra), got {shape.mesh_order}")
    if shape.mesh_unit not in UNITS:
        raise _err("body.mesh_unit", path, f'must be "m" or "mm", got {shape.mesh_unit!r}')
    sha = file_sha256(path, where)
    if getattr(shape, "mesh_sha256", None) and sha != shape.mesh_sha256:
        raise _err(where, path, "the file changed since the description was loaded; load the description again")
    geometry = suffix in GEOMETRY_SUFFIXES
    if not geometry and suffix not in MESH_SUFFIXES:
        known = ", ".join(MESH_SUFFIXES + GEOMETRY_SUFFIXES)
        raise _err(where, path, f"unknown suffix {suffix!r}; a body file is one of {known}")
    if geometry and shape.mesh_size_m is None:
        raise _err("mesh.size_m", path, "a geometry file needs the target element size [mesh] size_m (m)")
    if not geometry and shape.mesh_size_m is not None:
        raise _err("mesh.size_m", path, "is for geometry files (gmsh); a mesh file is used as it is")
    cached = mesh_cache_dir() / f"{_cache_key(sha, shape, geometry)}.npz"
    mesh = _load_cached(cached)
    if mesh is not None:
        return mesh
    scale = UNITS[shape.mesh_unit]
    if geometry:
        X, tets, groups = _mesh_geometry(path, shape.mesh_size_m / scale, where, shape.mesh_unit)
    else:
        X, tets, groups = _read_mesh_file(path, where)
    mesh = _checked(X * scale, tets, groups, path, where, shape.mesh_unit)
    _save_cached(cached, mesh)
    return mesh


def _read_mesh_file(path: Path, where: str):
    import meshio

    try:
        m = meshio.read(path)
    except (Exception, SystemExit) as exc:  # meshio raises many kinds (and may exit) for a malformed file
        raise _err(where, path, f"meshio cannot read it: {type(exc).__name__}: {exc}") from None
    blocks = [i for i, c in enumerate(m.cells) if c.type == "tetra"]
    if not blocks:
        raise _err(where, path, f"no tetrahedra ('tetra' cells) in the file, only {[c.type for c in m.cells]}")
    tets = np.concatenate([m.cells[i].data for i in blocks]).astype(np.int64)
    groups = {}
    for name, per_block in m.cell_sets.items():
        if name.startswith("gmsh:"):  # gmsh:bounding_entities holds entity tags, not cell indices
            continue
        nodes = [m.cells[i].data[np.asarray(idx, int)].ravel() for i, idx in enumerate(per_block) if idx is not None]
        if nodes:
            groups[name] = np.unique(np.concatenate(nodes))
    for name, idx in m.point_sets.items():
        groups[name] = np.unique(np.asarray(idx, np.int64))
    # A .msh 2.2 file has no cell sets: its named physical groups (any dimension) are the cells
    # whose gmsh:physical tag is the name's (field_data: name -> [tag, dim]).
    dims = {"vertex": 0, "line": 1, "triangle": 2, "quad": 2, "tetra": 3, "hexahedron": 3, "wedge": 3, "pyramid": 3}
    physical = m.cell_data.get("gmsh:physical", ())
    for name, (tag, dim) in ((k, np.ravel(v)[:2]) for k, v in m.field_data.items() if np.size(v) >= 2):
        nodes = [c.data[np.asarray(t) == tag].ravel() for c, t in zip(m.cells, physical) if dims.get(c.type) == dim]
        if name not in groups and sum(n.size for n in nodes):
            groups[name] = np.unique(np.concatenate(nodes)).astype(np.int64)
    return np.asarray(m.points, float)[:, :3], tets, groups


def _mesh_geometry(path: Path, size: float, where: str, unit: str):
    """Mesh a geometry with gmsh's Python API: one thread, target size ``size`` in the file's unit.

    Before meshing, the geometry's bounding box must be plausible in ``unit`` and hold at
    most :data:`MAX_GEOMETRY_TETS` tets of the target size (a unit mistake would otherwise
    ask gmsh for billions)."""
    import gmsh

    gmsh.initialize(["-nt", "1"], readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.NumThreads", 1)
        gmsh.option.setNumber("Mesh.MaxNumThreads3D", 1)

        def options():
            gmsh.option.setNumber("Mesh.MeshSizeMax", size)
            gmsh.option.setNumber("Mesh.MeshSizeMin", 0.1 * size)
            gmsh.option.setNumber("Mesh.ElementOrder", 1)
            gmsh.option.setNumber("Mesh.Optimize", 1)

        options()
        try:
            gmsh.open(str(path))
        except Exception as exc:
            raise _err(where, path, f"gmsh cannot read it: {exc}") from None
        options()  # after the file, whose own settings would otherwise win
        gmsh.model.mesh.clear()
        box = np.array(gmsh.model.getBoundingBox(-1, -1), float)
        sides = box[3:] - box[:3]
        _check_extent(float(np.max(sides)) * UNITS[unit], path, unit)
        estimate = 6.0 * float(np.prod(np.maximum(sides, size))) / size**3  # about 6 tets per cube of the size
        if estimate > MAX_GEOMETRY_TETS:
            raise _err(
                "mesh.size_m",
                path,
                f"{size * UNITS[unit]:g} m elements on a body of {np.round(sides * UNITS[unit], 4).tolist()} m would "
                f"make about {estimate:.2g} tets (at most {MAX_GEOMETRY_TETS:.0e}); use a larger size_m",
            )
        try:
            gmsh.model.mesh.generate(3)
        except Exception as exc:
            raise _err(where, path, f"gmsh could not mesh it: {exc}") from None
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, tet_nodes = gmsh.model.mesh.getElementsByType(4)
        if len(tet_nodes) == 0:
            raise _err(where, path, "gmsh made no tetrahedra (is there a closed volume in the geometry?)")
        index = np.full(int(tags.max()) + 1, -1, np.int64)
        index[tags.astype(np.int64)] = np.arange(len(tags))
        tets = index[np.asarray(tet_nodes, np.int64)].reshape(-1, 4)
        groups = {}
        for dim, tag in gmsh.model.getPhysicalGroups():
            name = gmsh.model.getPhysicalName(dim, tag) or f"{dim}:{tag}"
            nodes, _ = gmsh.model.mesh.getNodesForPhysicalGroup(dim, tag)
            groups[name] = np.unique(index[np.asarray(nodes, np.int64)])
        return np.asarray(coords, float).reshape(-1, 3), tets, groups
    finally:
        gmsh.finalize()


def _check_extent(extent: float, path, unit: str) -> None:
    """Refuse a body whose largest side (m) is implausible: a unit mistake."""
    lo, hi = PLAUSIBLE_EXTENT_M
    if not lo <= extent <= hi:
        hint = 'mesh_unit = "mm"?' if extent > hi else 'mesh_unit = "m" (is the file in metres)?'
        raise _err(
            "body.mesh_unit",
            path,
            f"the body is {extent:.4g} m across in unit {unit!r}, outside [{lo}, {hi}] m: {hint}",
        )


def _checked(X, tets, groups, path, where: str, unit: str) -> BodyMesh:
    """Drop unused nodes, check size, volumes, orientation and connectedness."""
    used = np.unique(tets)
    remap = np.full(len(X), -1, np.int64)
    remap[used] = np.arange(len(used))
    X, tets = np.ascontiguousarray(X[used]), remap[tets]
    groups = {k: np.unique(remap[v][remap[v] >= 0]) for k, v in groups.items()}
    _check_extent(float(np.max(X.max(axis=0) - X.min(axis=0))), path, unit)
    P = X[tets]
    vol = np.linalg.det(np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]], axis=-1)) / 6.0
    tiny = np.abs(vol) < DEGENERATE_FRACTION * np.median(np.abs(vol))
    if np.any(tiny):
        raise _err(
            where,
            path,
            f"{int(tiny.sum())} degenerate (zero-volume) tetrahedra, the first is tet {int(np.argmax(tiny))}",
        )
    neg = vol < 0
    if np.all(neg):
        tets = tets[:, [0, 2, 1, 3]]
    elif np.any(neg):
        bad = neg if neg.sum() <= (~neg).sum() else ~neg
        raise _err(
            where,
            path,
            f"{int(bad.sum())} of {len(tets)} tetrahedra are inverted (wound against the others), the first is "
            f"tet {int(np.argmax(bad))}",
        )
    sizes = _pieces(tets)
    if len(sizes) > 1:
        raise _err(
            where,
            path,
            f"the body is in {len(sizes)} disconnected pieces (tets joined through shared faces) of "
            f"{sorted(sizes.tolist(), reverse=True)} tets",
        )
    return BodyMesh(X, np.ascontiguousarray(tets, np.int64), groups)


def _pieces(tets: np.ndarray) -> np.ndarray:
    """The number of tets in each piece, tets joined through shared faces."""
    M = len(tets)
    faces = np.sort(np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]], tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]]), 1)
    owner = np.tile(np.arange(M), 4)
    _, inv = np.unique(faces, axis=0, return_inverse=True)
    order = np.argsort(inv.ravel(), kind="stable")
    s = inv.ravel()[order]
    pair = np.flatnonzero(s[1:] == s[:-1])
    a, b = owner[order[pair]], owner[order[pair + 1]]
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(M, M))
    n, labels = connected_components(graph, directed=False)
    return np.bincount(labels, minlength=n)


def clamped_nodes(body_mesh: BodyMesh, shape) -> np.ndarray:
    """The nodes held at rest: those at the base, or those of a named physical group.

    ``clamp = "base"`` holds the nodes with x <= x_min + 1e-6 x the body's extent. A CAD
    base is an exact plane, whose nodes gmsh places on it to rounding (~1e-15 relative);
    a mesh file written in ASCII with 7 or more significant digits moves them by at most
    ~1e-7 of the extent; 1e-6 covers both and is far below any element size a body would
    use (a mesh of elements 1e-6 of its size would have ~1e18 of them).

    Parameters
    ----------
    body_mesh : BodyMesh
        The mesh (m).
    shape : BodyShape
        Its ``clamp`` ("base" or None) and ``clamp_group`` (a group name or None).

    Returns
    -------
    ndarray of bool, shape (N,)
        True for a clamped node (MeshFileError naming the field if there is none, or the
        group is unknown).
    """
    X = body_mesh.X_m
    path = shape.mesh_file
    if shape.clamp_group is not None:
        if shape.clamp_group not in body_mesh.groups:
            raise _err(
                "body.clamp_group",
                path,
                f"no physical group {shape.clamp_group!r}; the file has {sorted(body_mesh.groups) or 'none'}",
            )
        out = np.zeros(len(X), bool)
        out[body_mesh.groups[shape.clamp_group]] = True
        where = "body.clamp_group"
    elif shape.clamp == "base":
        extent = float(np.max(X.max(axis=0) - X.min(axis=0)))
        out = X[:, 0] <= X[:, 0].min() + 1e-6 * extent
        where = "body.clamp"
    else:
        raise _err("body.clamp", path, f'must be "base" or give body.clamp_group, got {shape.clamp!r}')
    if not out.any():
        raise _err(where, path, "no node is clamped")
    return out
