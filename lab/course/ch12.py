"""Chapter 12's graders: the volume a closed triangle surface encloses, and its gradient.

Each ``check_*`` takes the student's function, draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched) and calls
:func:`lab.course.grade` against ``lab``'s own implementation or an independent computation:
for exercise 12.1 :func:`lab.fem.actuators.chamber_surfaces.cavity_volume`, the volume the
pressure chambers use, on closed surfaces of three kinds (random convex polyhedra, a
chamber's wall from a real mesh, bent, and both wound the wrong way round, where the signed
volume is negative); for 12.2 central differences of that same function, which are exact
here up to round-off (the volume is linear in any single node coordinate: each triangle
holds a node once). The references live here, out of the student's sight: a grader cell in
``notebooks/12_fluidic_arm.ipynb`` is one import and one call.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from lab.course.grading import Grade, grade
from lab.fem.actuators.chamber_surfaces import cavity_volume

__all__ = ["check_enclosed_volume", "check_volume_gradient"]


def _inward(points: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """The hull's triangles wound with their normals towards the centroid (into the cavity)."""
    c = points.mean(axis=0)
    a, b, d = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    out = np.einsum("ij,ij->i", np.cross(b - a, d - a), a - c) > 0  # normal points away from the centroid
    tri = tri.copy()
    tri[out] = tri[out][:, ::-1]
    return tri


def _polyhedron(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A random convex polyhedron (hull of 6-30 points, centimetres across, anywhere within
    a metre of the origin) with its triangles wound into the cavity; some nodes unused."""
    n = int(rng.integers(6, 31))
    p = rng.normal(0.0, 0.01, (n, 3)) * rng.uniform(0.3, 3.0, 3) + rng.uniform(-1.0, 1.0, 3)
    return p, _inward(p, ConvexHull(p).simplices)


def _chamber(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A chamber's wall as a tet mesh holds it: a hollow tube's cavity, closed at both ends,
    its nodes moved by a smooth random bend and a little noise (a non-convex surface)."""
    m, k = int(rng.integers(5, 13)), int(rng.integers(3, 9))  # sides, layers
    r, L = rng.uniform(0.003, 0.006), rng.uniform(0.05, 0.2)
    t = 2 * np.pi * np.arange(m) / m
    x = np.linspace(0.0, L, k + 1)
    ring = np.stack([np.column_stack([np.full(m, xi), r * np.cos(t), r * np.sin(t)]) for xi in x])
    nodes = np.vstack([ring.reshape(-1, 3), [[0.0, 0.0, 0.0], [L, 0.0, 0.0]]])
    c0, c1 = len(nodes) - 2, len(nodes) - 1
    tri = []
    for i in range(k):
        for j in range(m):
            a, b = i * m + j, i * m + (j + 1) % m
            tri += [[a, b + m, b], [a, a + m, b + m]]
    for j in range(m):
        tri += [[c0, (j + 1) % m, j], [c1, k * m + j, k * m + (j + 1) % m]]
    tri = _inward(nodes, np.array(tri))  # (a tube is star-shaped about its centroid along the axis)
    bend = rng.normal(0.0, 0.5, 2)
    nodes[:, 1:] += np.outer(nodes[:, 0] ** 2, bend) + rng.normal(0.0, 2e-4, (len(nodes), 2))
    return nodes, tri


def _surfaces(rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    cases = [_polyhedron(rng) for _ in range(4)] + [_chamber(rng) for _ in range(3)]
    cases += [(x, t[:, ::-1].copy()) for x, t in (_polyhedron(rng), _chamber(rng))]  # wound outwards
    return cases


def check_enclosed_volume(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 12.1: ``student(x_W, triangles)`` -> the signed volume (float, m^3) a closed
    triangle surface encloses, positive when the triangles (T, 3) are wound with normals
    into the cavity, against :func:`~lab.fem.actuators.chamber_surfaces.cavity_volume` on 9
    surfaces: random convex polyhedra far from the origin, bent tube-shaped chambers and one
    of each wound outwards (a negative volume)."""
    rng = np.random.default_rng(121)
    return grade(
        "the volume of a closed surface",
        student,
        cavity_volume,
        _surfaces(rng),
        rtol=1e-9,
        atol=1e-15,
        hint="cut the enclosed solid into tetrahedra that share one apex and add their signed volumes; then "
        "check the sign against the winding: which way does a triangle's normal point for a positive volume?",
        show=show,
        case=case,
        checker=check_enclosed_volume,
    )


def _gradient_by_differences(x_W, triangles) -> np.ndarray:
    """dV/dx (N, 3) m^2 by central differences of cavity_volume (exact: V is linear in each coordinate)."""
    x_W = np.asarray(x_W, dtype=float)
    g = np.zeros_like(x_W)
    used = np.unique(triangles)
    h = 1e-3 * max(float(np.ptp(x_W[used], axis=0).max()), 1e-9)
    for i in used:
        for k in range(3):
            xp, xm = x_W.copy(), x_W.copy()
            xp[i, k] += h
            xm[i, k] -= h
            g[i, k] = (cavity_volume(xp, triangles) - cavity_volume(xm, triangles)) / (2 * h)
    return g


def check_volume_gradient(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 12.2: ``student(x_W, triangles)`` -> dV/dx (N, 3) m^2, the derivative of the
    enclosed volume with respect to every node's position (zero rows for nodes on no
    triangle), against central differences of
    :func:`~lab.fem.actuators.chamber_surfaces.cavity_volume` on the surfaces of exercise 12.1."""
    rng = np.random.default_rng(122)
    return grade(
        "the volume's gradient",
        student,
        _gradient_by_differences,
        _surfaces(rng),
        rtol=1e-6,
        atol=1e-12,
        hint="each triangle's term is linear in each of its three vertices: differentiate it with respect to "
        "one vertex, then add every triangle's contribution into the rows of its nodes",
        show=show,
        case=case,
        checker=check_volume_gradient,
    )
