"""Chapters 8, 9 and 10's graders (lab.course.ch08, ch09, ch10) pass a right answer and catch
the wrong ones a student is likely to write.

Each grader runs without showing its result (``grade`` prints outside IPython; the output is
captured): a correct implementation, written independently of ``lab``'s, must pass, and each
wrong variant must fail. The exercises a student builds (8.1 a batch kept apart, 9.2 ILC over
passes, 10.2 the error on held-out sequences) are checked against several plausible mistakes.
"""

import numpy as np
from helpers import assert_reruns

from lab.course.ch08 import check_calibration, check_ensemble_spread, check_gp_jacobian, check_pick_apart
from lab.course.ch09 import check_frequency_response, check_ilc, check_step_response
from lab.course.ch10 import check_held_out_sequences, check_history_features, check_revisit_floor
from lab.tracking.closed_loop import damped_pinv


def _pick(x_pool, spread, x_data, n, radius, *, keep_apart=True, use_data=True, cap=True):
    d = np.full(len(x_pool), np.inf)
    if use_data:
        d = np.min(np.linalg.norm(x_pool[:, None] - x_data[None], axis=2), axis=1)
    picked = []
    for _ in range(n):
        ratio = d / radius
        score = spread * (np.minimum(1.0, ratio) if cap else ratio)
        score[picked] = -np.inf
        picked.append(int(np.argmax(score)))
        if keep_apart:
            d = np.minimum(d, np.linalg.norm(x_pool - x_pool[picked[-1]], axis=1))
    return np.array(picked)


def _passed(result) -> bool:
    return result.status == "passed"


def test_chapter_8_graders_pass_right_and_catch_wrong_answers():
    assert _passed(check_pick_apart(_pick, show=False))
    top_spreads = lambda x_pool, spread, x_data, n, radius: np.argsort(-spread)[:n]  # noqa: E731
    for wrong in (
        top_spreads,
        lambda *a: _pick(*a, keep_apart=False),
        lambda *a: _pick(*a, use_data=False),
        lambda *a: _pick(*a, cap=False),
    ):
        assert not _passed(check_pick_apart(wrong, show=False))
    assert_reruns(check_pick_apart(wrong, show=False), lambda k: check_pick_apart(wrong, case=k, show=False))

    def gp(x, X, alpha, ls, s2):
        k = s2 * np.exp(-0.5 * np.sum(((x - X) / ls) ** 2, axis=1))
        return k @ alpha, alpha.T @ (k[:, None] * (X - x) / ls**2)

    assert _passed(check_gp_jacobian(gp, show=False))
    wrong = lambda *a: (gp(*a)[0], -gp(*a)[1])  # noqa: E731
    assert_reruns(check_gp_jacobian(wrong, show=False), lambda k: check_gp_jacobian(wrong, case=k, show=False))

    spread = lambda f, ddof=1: (np.mean(f, axis=0), np.std(f, axis=0, ddof=ddof))  # noqa: E731
    assert _passed(check_ensemble_spread(spread, show=False))
    wrong = lambda f: spread(f, ddof=0)  # noqa: E731
    assert_reruns(check_ensemble_spread(wrong, show=False), lambda k: check_ensemble_spread(wrong, case=k, show=False))

    def within(y, m, s, k=(1.0, 2.0)):
        z = np.abs(y - m) / s
        return float(np.mean(z <= k[0])), float(np.mean(z <= k[1]))

    assert _passed(check_calibration(within, show=False))
    wrong = lambda y, m, s: within(y, m, s, (0.5, 1.0))  # noqa: E731
    assert_reruns(check_calibration(wrong, show=False), lambda k: check_calibration(wrong, case=k, show=False))


def _ilc(measure, jacobian, u0, targets, passes, gain, damping, step, *, clip=False, last=False, frozen=False):
    U = np.array(u0, dtype=float)
    J0 = [jacobian(u) for u in U]
    errors = []
    for k in range(passes):
        tips = measure(U)
        errors.append(np.mean(np.linalg.norm(tips - targets, axis=1)))
        if k == passes - 1 and not last:
            break
        for i in range(len(U)):
            du = gain * damped_pinv(J0[i] if frozen else jacobian(U[i]), damping) @ (targets[i] - tips[i])
            du = np.clip(du, -step, step) if clip else du * min(1.0, step / np.max(np.abs(du)))
            U[i] = U[i] + du
    return np.array(errors), U


def test_chapter_9_graders_pass_right_and_catch_wrong_answers():
    def covered(t, tau, w):
        t = np.asarray(t, float)
        return np.where(t > 0, 1 - sum(wk * np.exp(-np.clip(t, 0, None) / tk) for tk, wk in zip(tau, w)), 0.0)

    assert _passed(check_step_response(covered, show=False))
    wrong = lambda t, tau, w: covered(t, tau, w[::-1])  # noqa: E731
    assert_reruns(check_step_response(wrong, show=False), lambda k: check_step_response(wrong, case=k, show=False))

    assert _passed(check_ilc(_ilc, show=False))
    for wrong in ({"clip": True}, {"last": True}, {"frozen": True}):
        assert not _passed(check_ilc(lambda *a, kw=wrong: _ilc(*a, **kw), show=False)), wrong
    backwards = lambda m, j, u0, t, *a: _ilc(lambda U: 2 * t - m(U), j, u0, t, *a)  # noqa: E731
    assert_reruns(check_ilc(backwards, show=False), lambda k: check_ilc(backwards, case=k, show=False))

    def response(period_s, tau, w):
        H = np.sum(np.asarray(w) / (1 + 2j * np.pi / period_s * np.asarray(tau)))
        return float(abs(H)), float(np.angle(H))

    assert _passed(check_frequency_response(response, show=False))
    wrong = lambda T, tau, w: response(T / (2 * np.pi), tau, w)  # noqa: E731
    assert_reruns(
        check_frequency_response(wrong, show=False), lambda k: check_frequency_response(wrong, case=k, show=False)
    )


def test_chapter_10_graders_pass_right_and_catch_wrong_answers():
    def floor(u, y, pairs_of=lambda rows: [(a, b) for a in rows for b in rows if a < b]):
        groups = {}
        for i, row in enumerate(map(tuple, u)):
            groups.setdefault(row, []).append(i)
        d2 = [np.sum((y[a] - y[b]) ** 2) for rows in groups.values() for a, b in pairs_of(rows)]
        return float(np.sqrt(np.mean(d2) / 2)) if d2 else None

    assert _passed(check_revisit_floor(floor, show=False))
    consecutive = lambda rows: list(zip(rows, rows[1:]))  # noqa: E731 - misses the (first, third) pair
    wrong = lambda u, y: floor(u, y, consecutive)  # noqa: E731
    assert_reruns(check_revisit_floor(wrong, show=False), lambda k: check_revisit_floor(wrong, case=k, show=False))

    def held_out(u, y, seq, fit, *, leak=False, per_sequence=False, per_coordinate=False, blocks=False):
        groups = np.arange(len(u)) * len(np.unique(seq)) // len(u) if blocks else seq
        d2 = []
        for g in np.unique(groups):
            test = groups == g
            model = fit(u if leak else u[~test], y if leak else y[~test])
            e2 = (model.predict(u[test]) - y[test]) ** 2
            d2.append(e2 if per_coordinate else e2.sum(axis=1))
        if per_sequence:
            return float(np.mean([np.sqrt(np.mean(d)) for d in d2]))
        return float(np.sqrt(np.mean(np.concatenate(d2))))

    assert _passed(check_held_out_sequences(held_out, show=False))
    for wrong in ("leak", "per_sequence", "per_coordinate", "blocks"):
        assert not _passed(check_held_out_sequences(lambda *a, w=wrong: held_out(*a, **{w: True}), show=False)), wrong
    leak = lambda *a: held_out(*a, leak=True)  # noqa: E731
    assert_reruns(
        check_held_out_sequences(leak, show=False), lambda k: check_held_out_sequences(leak, case=k, show=False)
    )

    def history(u, seq, k, *, across=False):
        start = np.zeros(len(u), int)
        for i in range(1, len(u)):
            start[i] = start[i - 1] if across or seq[i] == seq[i - 1] else i
        return np.hstack([u[np.maximum(np.arange(len(u)) - j, start)] for j in range(k + 1)])

    assert _passed(check_history_features(history, show=False))
    wrong = lambda u, s, k: history(u, s, k, across=True)  # noqa: E731
    assert_reruns(
        check_history_features(wrong, show=False), lambda k: check_history_features(wrong, case=k, show=False)
    )
