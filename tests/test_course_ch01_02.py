"""Chapters 1 and 2's graders (lab.course.ch01, lab.course.ch02) pass a right answer and
catch the wrong ones a student is likely to write.

Each grader runs without showing its result (``show=False``): a correct implementation,
written here independently of ``lab``'s, must pass, and each wrong variant must fail. The
FEM and the emulated body use coarse meshes (chapter 1's and 2's quick mode).
"""

import numpy as np
import pytest
from helpers import assert_reruns
from scipy.sparse.linalg import spsolve

from lab.capture import SettleDetector
from lab.course.ch01 import WARM_FRACTION, check_cable_length, check_newton_solve, check_warm_walk, walk_cases
from lab.course.ch02 import check_capture_sample, check_first_settled, check_goal_ticks
from lab.fem import ArmFEM, solve_static
from lab.rig import AsBuiltBody


@pytest.fixture(scope="module")
def fem(three_cable):
    return ArmFEM(three_cable, n_rings=1, n_axial=8)


# --- chapter 1 ------------------------------------------------------------------------


def _cable_length(anchor_W, via_W, leaving=True):
    points = np.vstack([anchor_W, via_W])
    seg = points[1:] - points[:-1]
    unit = seg / np.linalg.norm(seg, axis=1, keepdims=True)
    grad = unit.copy()
    if leaving:
        grad[:-1] = grad[:-1] - unit[1:]
    return float(np.linalg.norm(seg, axis=1).sum()), grad


def test_cable_length_grader():
    assert check_cable_length(_cable_length, show=False).status == "passed"
    wrong = lambda a, v: _cable_length(a, v, leaving=False)  # noqa: E731
    assert_reruns(check_cable_length(wrong, show=False), lambda k: check_cable_length(wrong, case=k, show=False))


def _newton(fem, u, q0, tol_step_m=1e-7, steps=100):
    q = np.array(q0, float)
    for _ in range(steps):
        dq = spsolve(fem.hessian(q, u).tocsc(), -fem.gradient(q, u))
        if np.abs(dq).max() <= tol_step_m:
            return q + dq
        alpha, energy = 1.0, fem.energy(q, u)
        while not fem.energy(q + alpha * dq, u) < energy:
            alpha /= 2
        q = q + alpha * dq
    return q


def test_newton_grader(fem, three_cable):
    sols = {k: solve_static(fem, u) for k, u in (("rest", [0, 0, 0]), ("top", [3, 0, 0]), ("mixed", [2, 1, 0.5]))}
    assert check_newton_solve(_newton, fem, sols, show=False).status == "passed"
    for wrong in (
        lambda fem, u, q0: np.array(q0),  # no step at all
        lambda fem, u, q0: _newton(fem, u, q0, steps=1),  # one step
        lambda fem, u, q0: _newton(fem, u, q0, tol_step_m=1e-4),  # stops far too early
    ):
        assert check_newton_solve(wrong, fem, sols, show=False).status == "failed"
    assert_reruns(
        check_newton_solve(wrong, fem, sols, show=False),
        lambda k: check_newton_solve(wrong, fem, sols, case=k, show=False),
    )


def _walk(fem, u_path, start="prediction"):
    sols, prev = [], None
    for u in u_path:
        q0 = None
        if prev is not None and start == "prediction":
            q0 = prev.q + prev.dq_du @ (u - prev.u_motor)
        elif prev is not None and start == "previous":
            q0 = prev.q
        prev = solve_static(fem, u, q0, sensitivity=True)
        sols.append(prev)
    return sols


def test_warm_walk_grader(fem):
    assert check_warm_walk(_walk, fem, show=False).status == "passed"
    # the margin: a first-order prediction needs clearly fewer iterations than the bound
    fem_, path = walk_cases(fem)[0]
    warm = sum(s.iterations for s in _walk(fem, path))
    cold = sum(solve_static(fem, u).iterations for u in path)
    assert warm < 0.7 * cold and WARM_FRACTION * cold < sum(s.iterations for s in _walk(fem, path, "previous"))
    for start in ("rest", "previous"):
        wrong = lambda fem, p, s=start: _walk(fem, p, s)  # noqa: E731
        result = check_warm_walk(wrong, fem, show=False)
        assert result.status == "failed" and "NotWarmStarted" in result, result
    assert_reruns(result, lambda k: check_warm_walk(wrong, fem, case=k, show=False))
    skipped = check_warm_walk(lambda fem, p: _walk(fem, p)[:-1], fem, show=False)
    assert skipped.status == "failed" and "expected 8 solutions" in skipped


# --- chapter 2 ------------------------------------------------------------------------


def test_goal_ticks_grader(three_cable):
    def ticks(u, zero, direction, rounding=np.rint):
        return np.asarray(zero) + np.asarray(direction) * rounding(np.asarray(u) * 4096 / (2 * np.pi)).astype(int)

    assert check_goal_ticks(ticks, three_cable.u_max_rad, show=False).status == "passed"
    assert (
        check_goal_ticks(lambda *a: ticks(*a, rounding=np.floor), three_cable.u_max_rad, show=False).status == "failed"
    )
    wrong = lambda u, z, d: ticks(u, z, 1)  # noqa: E731
    result = check_goal_ticks(wrong, three_cable.u_max_rad, show=False)
    assert_reruns(result, lambda k: check_goal_ticks(wrong, three_cable.u_max_rad, case=k, show=False))


def _first_settled(readings, n_previous=20, tol_m=1e-4, valid_only=True):
    history = []
    for k, r in enumerate(readings):
        if valid_only and not np.all(np.isfinite(r)):
            continue
        if len(history) >= n_previous and np.linalg.norm(r - np.mean(history[-n_previous:], axis=0)) <= tol_m:
            return k
        history.append(r)
    return -1


def test_settle_test_grader():
    assert check_first_settled(_first_settled, show=False).status == "passed"
    including_current = (
        lambda r, n=20, tol=1e-4: next(  # noqa: E731
            (k for k in range(n, len(r)) if np.linalg.norm(r[k] - np.nanmean(r[k - n : k + 1], axis=0)) <= tol), -1
        )
    )
    result = check_first_settled(including_current, show=False)
    assert_reruns(result, lambda k: check_first_settled(including_current, case=k, show=False))


def _capture(rig, u, reset=True, release=True, wait=True):
    def reading():
        points = [f.p_tip_W for f in rig.wait(0.1) if f.valid]
        return np.mean(points, axis=0) if points else np.full(3, np.nan)

    def go_to(goal):
        goal = rig.send(goal)
        while np.abs(rig.present_u() - goal).max() > 0.01:
            rig.next_frame()

    m = rig.robot.n_cables
    if reset:
        go_to(np.ones(m))
        if release:
            go_to(np.zeros(m))
    go_to(u)
    if not wait:
        rig.wait(0.5)
        return reading()
    detector = SettleDetector(20, 1e-4)
    while not detector.update(r := reading()):
        pass
    return r


@pytest.fixture(scope="module")
def body(three_cable):
    return AsBuiltBody(three_cable, None, n_rings=2, n_axial=6)


def test_capture_grader(body):
    # polls the motors frame by frame: its readings are not aligned with measure's, and it passes
    assert check_capture_sample(_capture, body, show=False).status == "passed"
    for wrong in (
        lambda rig, u: _capture(rig, u, reset=False),
        lambda rig, u: _capture(rig, u, release=False),
        lambda rig, u: _capture(rig, u, wait=False),
    ):
        assert check_capture_sample(wrong, body, show=False).status == "failed"
    assert_reruns(
        check_capture_sample(wrong, body, show=False), lambda k: check_capture_sample(wrong, body, case=k, show=False)
    )
    assert body.time_s == 0.0  # the grader drove copies


def test_capture_grader_stops_an_endless_loop(body):
    def polls_forever(rig, u):
        rig.send(u)
        while True:
            rig.present_u()

    result = check_capture_sample(polls_forever, body, show=False)
    assert result.status == "failed" and "without a frame" in result
