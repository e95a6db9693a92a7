"""Chapters 5, 6 and 7's graders (lab.course.ch05, ch06, ch07) pass a right answer and
catch the wrong ones a student is likely to write.

Each grader runs without showing its result: a correct implementation, written here
independently of ``lab``'s, must pass, and each wrong variant must fail: for the
cross-validation of exercise 5.3 a per-fold average, a fit that saw its held-out samples
and the squared distance; for the walk along the family of solutions of exercise 6.1 no
correction, a single one, one along the Jacobian at the new command, a step along the whole
direction or of the wrong length, and a walk that ignores the allowed set or keeps the command
that leaves it; for the walk of exercise 6.2 a walk without the polish, a pull towards the
previous command only and cold starts; for the split study of exercise 7.1 the
MSE and seeds that are not ``run_seeds``'.
"""

from pathlib import Path

import numpy as np
import pytest
from helpers import assert_reruns

from lab.control import CommandSet
from lab.course.ch05 import check_gp_jacobian, check_maximin_order, check_prior_weight
from lab.course.ch06 import check_regularised_walk, check_walk_in_place
from lab.course.ch07 import check_mean_test_distance, check_median_and_quartiles
from lab.data import read_dataset
from lab.description import load_robot
from lab.learn import load_model, run_seeds, size_sweep, train

ROOT = Path(__file__).resolve().parent.parent


# ---- chapter 5 ------------------------------------------------------------------------


def _maximin(pool, first, n, nearest=True):
    chosen = [first]
    while len(chosen) < n:
        d = np.linalg.norm(pool[:, None, :] - pool[chosen][None], axis=2)  # (P, chosen)
        chosen.append(int(np.argmax(d.min(axis=1) if nearest else d[:, -1])))
    return chosen


def _gp_jacobian(X, alpha, ls, s2, u, scale=True):
    k = s2 * np.exp(-0.5 * np.sum(((u - X) / ls) ** 2, axis=1))  # (N,)
    dk = -k[:, None] * (u - X) / (ls**2 if scale else ls)  # (N, m)
    return np.einsum("nk,nj->kj", alpha, dk)


def _cross_validation(how="right"):
    def choose(fit, u, y, lambdas, folds):
        errors = []
        for lam in lambdas:
            per_sample, per_fold = [], []
            for test in folds:
                keep = np.ones(len(u), bool)
                keep[test] = how == "leak"
                d = np.linalg.norm(fit(u[keep], y[keep], lam).predict(u[test]) - y[test], axis=1)
                per_sample += list(d**2 if how == "squared" else d)
                per_fold.append(d.mean())
            errors.append(np.mean(per_fold if how == "per-fold" else per_sample))
        return lambdas[int(np.argmin(errors))], np.array(errors)

    return choose


def test_chapter_5_graders_pass_right_and_catch_wrong_answers():
    assert check_maximin_order(_maximin, show=False).status == "passed"
    wrong = lambda p, f, n: _maximin(p, f, n, nearest=False)  # noqa: E731
    assert_reruns(check_maximin_order(wrong, show=False), lambda k: check_maximin_order(wrong, case=k, show=False))
    assert check_gp_jacobian(_gp_jacobian, show=False).status == "passed"
    wrong = lambda *a: _gp_jacobian(*a, scale=False)  # noqa: E731
    assert_reruns(check_gp_jacobian(wrong, show=False), lambda k: check_gp_jacobian(wrong, case=k, show=False))
    sim_model = load_model(ROOT / "data" / "model_sim_three_cable.npz")
    u, y, _ = read_dataset(ROOT / "data" / "real_three_cable.csv")
    pick = np.random.default_rng(5).choice(len(u), 30, replace=False)
    assert check_prior_weight(_cross_validation(), sim_model, u[pick], y[pick], show=False).status == "passed"
    for wrong in ("per-fold", "leak", "squared"):
        result = check_prior_weight(_cross_validation(wrong), sim_model, u[pick], y[pick], show=False)
        assert result.status == "failed", wrong
    choose = _cross_validation("squared")
    assert_reruns(
        check_prior_weight(choose, sim_model, u[pick], y[pick], show=False),
        lambda k: check_prior_weight(choose, sim_model, u[pick], y[pick], case=k, show=False),
    )


# ---- chapter 6 ------------------------------------------------------------------------


def _walk_in_place(how="right"):
    def walk(model, commands, u_start, direction, step, n_steps):
        # independent of lab's: the null space from the SVD, Newton on the three multipliers of J's rows
        u, out = np.array(u_start, float), [np.array(u_start, float)]
        tip = model.predict(u)
        for _ in range(n_steps):
            J = model.jacobian(u)
            null = np.linalg.svd(J)[2][3:]  # (3, 6): an orthonormal basis of what J cannot see
            d = direction if how == "whole direction" else null.T @ (null @ direction)
            v = u + step * (d if how == "unscaled" else d / np.linalg.norm(d))
            for _ in range(0 if how == "no correction" else 1 if how == "one correction" else 50):
                miss = model.predict(v) - tip
                if np.linalg.norm(miss) < 1e-13:
                    break
                if how == "new jacobian":  # corrects along the rows of J at v, not at u
                    v = v - np.linalg.pinv(model.jacobian(v)) @ miss
                else:
                    v = v - J.T @ np.linalg.solve(model.jacobian(v) @ J.T, miss)
            if not commands.contains(v) and how != "ignores the set":
                if how == "keeps the last":
                    out.append(v)
                break
            u = v
            out.append(u)
        return np.array(out)

    return walk


def _walk(how="right"):
    def walk(solver, targets, u_start):
        w_c, w_p = solver.config.reg_weight, solver.config.posture_weight
        u, out = np.array(u_start, float), []
        for target in targets:
            start = solver.u_posture if how == "cold" else u
            ref = u if how == "previous only" else (w_c * u + w_p * solver.u_posture) / (w_c + w_p)
            u = solver.solve(target, start, u_ref=ref, reg_weight=w_c + w_p).u_motor
            if how != "no polish":
                u = solver.solve(target, u, reg_weight=0.0).u_motor
            out.append(u)
        return np.array(out)

    return walk


@pytest.fixture(scope="module")
def six_cable():
    return load_model(ROOT / "data" / "model_sim_six_cable.npz"), CommandSet.from_robot(load_robot("six-cable"))


def test_chapter_6_graders_pass_right_and_catch_wrong_answers(six_cable):
    model, commands = six_cable
    assert check_walk_in_place(_walk_in_place(), model, commands, show=False).status == "passed"
    wrong_walks = ("no correction", "one correction", "new jacobian", "whole direction", "unscaled")
    for wrong in (*wrong_walks, "ignores the set", "keeps the last"):
        assert check_walk_in_place(_walk_in_place(wrong), model, commands, show=False).status == "failed", wrong
    walk = _walk_in_place("one correction")
    assert_reruns(
        check_walk_in_place(walk, model, commands, show=False),
        lambda k: check_walk_in_place(walk, model, commands, case=k, show=False),
    )
    assert check_regularised_walk(_walk(), model, commands, show=False).status == "passed"
    for wrong in ("no polish", "previous only", "cold"):
        assert check_regularised_walk(_walk(wrong), model, commands, show=False).status == "failed", wrong
    walk = _walk("no polish")
    assert_reruns(
        check_regularised_walk(walk, model, commands, show=False),
        lambda k: check_regularised_walk(walk, model, commands, case=k, show=False),
    )


# ---- chapter 7 ------------------------------------------------------------------------


def _one_width(how="right"):
    def mean_test_distance(u, y, width, n_runs, seed, epochs):
        seeds = run_seeds(seed, n_runs) if how != "seed + r" else [seed + r for r in range(n_runs)]
        out = []
        for s in seeds:
            fit = train(u, y, (width, width), ratios=(0.8, 0.1, 0.1), seed=s, epochs=epochs)
            err = fit.model.predict(u[fit.split.test]) - y[fit.split.test]
            out.append(np.mean(err**2) if how == "mse" else np.mean(np.sqrt(np.sum(err**2, axis=1))))
        return float(np.mean(out))

    return mean_test_distance


def _quartiles(width, d, method="linear"):
    width, d = np.asarray(width), np.asarray(d, float)
    ws = sorted(set(width.tolist()))
    q = np.array([np.quantile(d[width == w], [0.5, 0.25, 0.75], method=method) for w in ws])
    return np.array(ws, float), q[:, 0], q[:, 1], q[:, 2]


def test_chapter_7_graders_pass_right_and_catch_wrong_answers():
    u, y, _ = read_dataset(ROOT / "data" / "sim_three_cable.csv")
    assert check_mean_test_distance(_one_width(), u, y, show=False).status == "passed"
    for wrong in ("mse", "seed + r"):
        assert check_mean_test_distance(_one_width(wrong), u, y, show=False).status == "failed", wrong
    width = _one_width("seed + r")
    assert_reruns(
        check_mean_test_distance(width, u, y, show=False),
        lambda k: check_mean_test_distance(width, u, y, case=k, show=False),
    )
    sweeps = [size_sweep(u, y, [2, 4], n_runs=3, seed=1, epochs=3)]
    assert check_median_and_quartiles(_quartiles, sweeps, show=False).status == "passed"
    nearest = lambda w, d: _quartiles(w, d, method="nearest")  # noqa: E731
    assert_reruns(
        check_median_and_quartiles(nearest, sweeps, show=False),
        lambda k: check_median_and_quartiles(nearest, sweeps, case=k, show=False),
    )
