"""Chapter 11's graders: a tapered body's radius, a marker on a stalk, an angle cable's tension.

Each ``check_*`` takes the student's function, draws its own cases from its own seeded
``np.random.default_rng`` (the chapter's random stream is untouched) and calls
:func:`lab.course.grade` against ``lab``'s own implementation or an independent computation:
for exercise 11.1 the radius of :func:`lab.fem.bodies.tapered_mesh`'s layers (its mesh's
outermost nodes, which lie on the profile); for 11.3 a least-squares fit written here with
:func:`numpy.linalg.lstsq`, the affine motion :mod:`lab.fem.bodies.markers` gives a stalk
marker; for 11.2 the description's one-sided spring,
:func:`lab.fem.actuators.cable_routes.spring`. The references live here, out of the
student's sight: a grader cell in ``notebooks/11_any_soft_body.ipynb`` is one import and
one call.
"""

from __future__ import annotations

import numpy as np

from lab.course.grading import Grade, grade
from lab.fem.actuators.cable_routes import spring
from lab.fem.bodies.tapered import tapered_mesh

__all__ = ["check_radius_profile", "check_stalk_marker", "check_cable_tension"]


def _profile(rng: np.random.Generator) -> np.ndarray:
    """A random profile (S, 2) m: 2-5 stations from x = 0, radii 5-40 mm."""
    n = int(rng.integers(2, 6))
    x = np.concatenate([[0.0], np.cumsum(rng.uniform(0.02, 0.15, n - 1))])
    return np.column_stack([x, rng.uniform(0.005, 0.04, n)])


def _radius_by_mesh(profile_m, x_m) -> np.ndarray:
    """The radius at ``x_m`` (P,) m of lab's tapered mesh with a layer at each of them.

    The mesh's layers sit at ``linspace(0, L, n_axial + 1)``; a layer's outermost node lies
    on the profile, so each query point is made a layer of its own mesh."""
    profile_m = np.asarray(profile_m, float)
    L = profile_m[-1, 0]
    n = 1000
    X = tapered_mesh(profile_m, 1, n).X_W
    layers = np.round(X[:, 0] / L * n).astype(int)
    r = np.zeros(n + 1)
    np.maximum.at(r, layers, np.linalg.norm(X[:, 1:], axis=1))
    return r[np.round(np.atleast_1d(x_m) / L * n).astype(int)]  # the cases' x sit on the layers


def check_radius_profile(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 11.1: ``student(profile_m, x_m)`` -> radii (P,) m at ``x_m`` (P,) m of the
    piecewise-linear profile ``profile_m`` (S, 2) [x, r] m, against the outermost nodes of
    :func:`~lab.fem.bodies.tapered_mesh` on 5 random profiles (2-5 stations), the stations
    themselves among the query points."""
    rng = np.random.default_rng(111)
    cases = []
    for _ in range(5):
        profile = _profile(rng)
        L = profile[-1, 0]
        grid = np.round(profile[:, 0] / L * 1000) * L / 1000  # the stations, on the mesh's layers
        x = np.concatenate([grid, rng.integers(0, 1001, 4) * L / 1000])
        cases.append((profile, x))
    return grade(
        "radius of a tapered body",
        student,
        _radius_by_mesh,
        cases,
        rtol=1e-9,
        atol=1e-12,
        hint="find the two stations around each x and interpolate the radius linearly between them",
        show=show,
        case=case,
        checker=check_radius_profile,
    )


def _stalk_by_lstsq(X_nodes, x_nodes, X_a, P):
    """The stalk marker at rest point ``P`` (3,) m: c + F (P - X_a), (c, F) fitted by least squares."""
    A = np.column_stack([np.ones(len(X_nodes)), X_nodes - X_a])
    coef, *_ = np.linalg.lstsq(A, x_nodes, rcond=None)  # rows: c, then F^T
    return coef[0] + (P - X_a) @ coef[1:]


def _stalk_case(rng: np.random.Generator) -> tuple:
    """16-40 nodes around a surface point, moved by a rotation, a stretch and a little bend."""
    n = int(rng.integers(16, 41))
    X_a = rng.uniform(-0.1, 0.1, 3)
    X_nodes = X_a + rng.normal(0.0, 0.01, (n, 3))
    angle = rng.uniform(-1.0, 1.0)
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    F = R @ (np.eye(3) + rng.normal(0.0, 0.1, (3, 3)))
    d = X_nodes - X_a
    bend = 20.0 * np.outer(d[:, 0] ** 2, rng.normal(0.0, 1.0, 3))  # not affine: the fit is a least-squares one
    x_nodes = rng.normal(0.0, 0.05, 3) + X_a + d @ F.T + bend
    P = X_a + rng.normal(0.0, 0.01, 3)
    return X_nodes, x_nodes, X_a, P


def check_stalk_marker(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 11.3: ``student(X_nodes, x_nodes, X_a, P)`` -> (3,) m, the marker on a stalk
    at rest point ``P`` moved with the least-squares affine motion x ~ c + F (X - X_a) of the
    nodes (rest ``X_nodes`` (n, 3) m, deformed ``x_nodes`` (n, 3) m) about ``X_a`` (3,) m,
    against a least-squares fit on 6 random neighbourhoods (16-40 nodes, rotated, stretched
    and slightly bent, so the fit is not exact)."""
    rng = np.random.default_rng(112)
    return grade(
        "a marker on a stalk",
        student,
        _stalk_by_lstsq,
        [_stalk_case(rng) for _ in range(6)],
        rtol=1e-8,
        atol=1e-12,
        hint="fit the 12 numbers of c and F to all the nodes at once (a linear least-squares problem); "
        "the marker is then c + F (P - X_a)",
        show=show,
        case=case,
        checker=check_stalk_marker,
    )


def _spring_tension(L_m, L0_m, r_m, u_rad, k_n_m, eps_m):
    return spring(L_m - (L0_m - r_m * u_rad), k_n_m, eps_m)[1]


def check_cable_tension(student, *, case: int | None = None, show: bool = True) -> Grade:
    """Exercise 11.2: ``student(L_m, L0_m, r_m, u_rad, k_n_m, eps_m)`` -> tensions (P,) N of
    angle-controlled cables of lengths ``L_m`` (P,) m, rest length ``L0_m`` m, spool radius
    ``r_m`` m at angles ``u_rad`` (P,) rad, against the description's one-sided spring
    (:func:`lab.fem.actuators.cable_routes.spring`) on 5 random cases, each with slack cables,
    cables in the smoothing band and taut ones."""
    rng = np.random.default_rng(113)
    cases = []
    for _ in range(5):
        L0, r = rng.uniform(0.1, 0.4), rng.uniform(0.004, 0.02)
        k, eps = rng.uniform(1e3, 1e4), rng.uniform(1e-4, 1e-3)
        u = rng.uniform(0.0, 3.0, 9)
        d = np.concatenate([-rng.uniform(0, 5 * eps, 3), rng.uniform(0, eps, 3), eps + rng.uniform(0, 0.01, 3)])
        cases.append((L0 - r * u + d, L0, r, u, k, eps))
    return grade(
        "an angle cable's tension",
        student,
        _spring_tension,
        cases,
        rtol=1e-9,
        atol=1e-12,
        hint="the free length is L0 - r u; the stretch is L minus it; three pieces: slack, the smoothing band, taut",
        show=show,
        case=case,
        checker=check_cable_tension,
    )
