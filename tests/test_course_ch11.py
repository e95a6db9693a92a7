"""Chapter 11's graders (lab.course.ch11) pass a right answer and catch the wrong ones a
student is likely to write.

Each correct implementation below is written independently of the grader's reference (the
radius by ``np.interp``, not by the mesh; the stalk by a pseudo-inverse, not ``lstsq``; the
tension piece by piece, not by the spring's clipped sums).
"""

import numpy as np
from helpers import assert_reruns

from lab.course.ch11 import check_cable_tension, check_radius_profile, check_stalk_marker


def _passed(result) -> bool:
    return result.status == "passed"


def test_radius_profile_grader():
    assert _passed(check_radius_profile(lambda p, x: np.interp(x, p[:, 0], p[:, 1]), show=False))
    # the radius of the nearest station, and a linear taper from the first to the last station
    nearest = lambda p, x: p[np.argmin(np.abs(x[:, None] - p[None, :, 0]), axis=1), 1]  # noqa: E731
    ends = lambda p, x: p[0, 1] + (p[-1, 1] - p[0, 1]) * x / p[-1, 0]  # noqa: E731
    for wrong in (nearest, ends):
        assert not _passed(check_radius_profile(wrong, show=False))
    assert_reruns(check_radius_profile(wrong, show=False), lambda k: check_radius_profile(wrong, case=k, show=False))


def _affine(X, x, Xa, P, centre=True):
    A = np.column_stack([np.ones(len(X)), X - Xa if centre else X])
    coef = np.linalg.pinv(A) @ x
    return coef[0] + ((P - Xa) if centre else P) @ coef[1:]


def test_stalk_marker_grader():
    assert _passed(check_stalk_marker(_affine, show=False))
    translated = lambda X, x, Xa, P: x.mean(0) + (P - X.mean(0))  # noqa: E731  (rigid shift only)
    nearest_node = lambda X, x, Xa, P: x[np.argmin(np.linalg.norm(X - P, axis=1))]  # noqa: E731
    about_origin_but_from_Xa = lambda X, x, Xa, P: _affine(X, x, Xa, P, centre=False) + 0 * Xa  # noqa: E731
    assert _passed(check_stalk_marker(about_origin_but_from_Xa, show=False))  # the same affine map: right too
    for wrong in (translated, nearest_node):
        assert not _passed(check_stalk_marker(wrong, show=False))
    assert_reruns(check_stalk_marker(wrong, show=False), lambda k: check_stalk_marker(wrong, case=k, show=False))


def _tension(L, L0, r, u, k, eps, smooth=True, sign=-1):
    d = L - (L0 + sign * r * u)
    if not smooth:
        return k * np.maximum(d, 0.0)
    return np.where(d <= 0, 0.0, np.where(d < eps, k * d**2 / (2 * eps), k * (d - eps / 2)))


def test_cable_tension_grader():
    assert _passed(check_cable_tension(_tension, show=False))
    for wrong in (
        lambda *a: _tension(*a, smooth=False),  # no smoothing band
        lambda *a: _tension(*a, sign=+1),  # the spool lengthens the cable
        lambda L, L0, r, u, k, eps: k * (L - (L0 - r * u)),  # two-sided: pushes when slack
    ):
        assert not _passed(check_cable_tension(wrong, show=False))
    assert_reruns(check_cable_tension(wrong, show=False), lambda k: check_cable_tension(wrong, case=k, show=False))
