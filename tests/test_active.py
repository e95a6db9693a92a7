"""Active sampling (lab.learn.active): picks where the ensemble disagrees, in batches, resumable."""

import numpy as np
import pytest

from lab.description import load_robot
from lab.errors import InputError, LabRuntimeError
from lab.learn.active import ActiveSpec, active_sampling, default_initial, pick_apart, pool_density


@pytest.fixture(scope="module")
def robot():
    return load_robot("three-cable")


def in_corner(robot, u):
    """The corner u0 high, u1 and u2 low (safe: its sum is at most 1.3 u_max)."""
    x = np.asarray(u) / robot.u_max_rad
    return (x[:, 0] > 0.7) & (x[:, 1] < 0.3) & (x[:, 2] < 0.3)


class CornerEnsemble:
    """A fake ensemble whose members disagree 100x more in one corner of the command box."""

    def __init__(self, robot, u, y, seed):
        self.robot, self.n_data, self.seed = robot, len(u), seed

    def predict_with_std(self, u_pool):
        s = np.where(in_corner(self.robot, u_pool), 1e-2, 1e-4)
        return np.zeros((len(u_pool), 3)), np.repeat(s[:, None], 3, axis=1) / np.sqrt(3)


def corner_fit(robot, calls):
    def fit(u, y, *, hidden, k, seed, epochs):
        calls.append((len(u), hidden, k, seed, epochs, u.copy(), y.copy()))
        return CornerEnsemble(robot, u, y, seed)

    return fit


def tip(u):
    """A stand-in for the arm: a smooth map (B, 3) rad -> (B, 3) m."""
    return 0.01 * np.column_stack([np.sin(u[:, 0]), np.cos(u[:, 1]) * u[:, 2], u.sum(axis=1)])


def test_picks_land_where_the_ensemble_disagrees(robot):
    calls, measured = [], []

    def measure(u_b):
        measured.append(len(u_b))
        return tip(u_b)

    spec = ActiveSpec(45, 8, n_initial=16, k=3, hidden=(4,), epochs=7, seed=1)
    u, y, log = active_sampling(robot, measure, spec, fit_ensemble=corner_fit(robot, calls))
    assert u.shape == (45, 3) and y.shape == (45, 3) and np.array_equal(y, tip(u))
    assert measured == [16, 8, 8, 8, 5]  # initial design, full batches, the remainder
    assert np.all(robot.is_safe(u))
    assert in_corner(robot, u[:16]).mean() < 0.2  # the initial design covers the box
    assert np.all(in_corner(robot, u[16:]))  # every active pick is in the corner
    assert len({tuple(r) for r in u}) == 45  # no command twice
    # each fit sees all the data measured so far, with the ensemble's settings
    assert [c[0] for c in calls] == [16, 24, 32, 40]
    assert all(c[1:3] == ((4,), 3) and c[4] == 7 for c in calls)
    assert np.array_equal(calls[-1][5], u[:40]) and np.array_equal(calls[-1][6], y[:40])
    assert [e["kind"] for e in log] == ["initial"] + ["active"] * 4
    assert [e["batch"] for e in log] == [0, 1, 2, 3, 4] and [e["n"] for e in log] == measured
    for e in log[1:]:
        assert e["picked_spread_max_m"] == pytest.approx(1e-2) and e["picked_spread_mean_m"] == pytest.approx(1e-2)
        assert e["pool_spread_max_m"] == pytest.approx(1e-2) and 1e-4 < e["pool_spread_mean_m"] < 2e-3


def test_a_batch_is_kept_apart(robot):
    """Picks spread over the disagreeing corner rather than clustering at its peak."""

    class Peaked(CornerEnsemble):
        def predict_with_std(self, u_pool):  # a sharp peak at one command of the corner
            x = u_pool / self.robot.u_max_rad
            s = 1e-2 * np.exp(-np.sum((x - [0.9, 0.05, 0.05]) ** 2, axis=1) / 0.02) + 1e-5
            return np.zeros((len(u_pool), 3)), np.column_stack([s, 0 * s, 0 * s])

    def fit(u, y, **kw):
        return Peaked(robot, u, y, kw["seed"])

    def batch(radius):
        u, _, _ = active_sampling(robot, tip, ActiveSpec(18, 10, n_initial=8, seed=0, radius=radius), fit_ensemble=fit)
        x = u[8:] / robot.u_max_rad
        d = np.linalg.norm(x[:, None] - x[None], axis=2)
        np.fill_diagonal(d, np.inf)
        return d.min(axis=1).mean(), np.linalg.norm(x - [0.9, 0.05, 0.05], axis=1).max()

    apart, near = batch(None)  # the default radius, 0.5 * 18^(-1/3) = 0.19
    clustered, _ = batch(1e-9)  # by spread alone
    assert apart > 1.3 * clustered  # nearest neighbours within the batch farther apart
    assert near < 0.3  # but still around the peak


def test_resume_gives_the_uninterrupted_run(robot):
    kw = dict(n_initial=12, k=2, seed=3, pool_size=512)

    def fit(u, y, *, hidden, k, seed, epochs):  # spread depends on the data and the seed
        rng = np.random.default_rng(seed)
        centre = y.mean(axis=0)

        class E:
            def predict_with_std(self, u_pool):
                x = u_pool / robot.u_max_rad
                s = 1e-3 * (1 + x @ rng.random(3) + np.linalg.norm(tip(u_pool) - centre, axis=1))
                return np.zeros((len(u_pool), 3)), np.column_stack([s, s, s])

        return E()

    full_u, full_y, full_log = active_sampling(robot, tip, ActiveSpec(42, 7, **kw), fit_ensemble=fit)

    class Killed(Exception):
        pass

    saved_u, saved_y, n_calls = [], [], [0]

    def dying(u_b):
        n_calls[0] += 1
        if n_calls[0] == 4:  # killed while measuring the third active batch
            raise Killed
        return tip(u_b)

    def keep(u_b, y_b, entry):
        saved_u.append(u_b), saved_y.append(y_b)

    with pytest.raises(Killed):
        active_sampling(robot, dying, ActiveSpec(42, 7, **kw), fit_ensemble=fit, on_batch=keep)
    u_done, y_done = np.vstack(saved_u), np.vstack(saved_y)
    assert len(u_done) == 12 + 7 + 7
    u, y, log = active_sampling(robot, tip, ActiveSpec(42, 7, **kw), fit_ensemble=fit, u_done=u_done, y_done=y_done)
    assert np.array_equal(u, full_u) and np.array_equal(y, full_y)
    strip = [{k: v for k, v in e.items() if k != "fit_s"} for e in full_log[3:]]
    assert [{k: v for k, v in e.items() if k != "fit_s"} for e in log] == strip
    assert [(e["batch"], e["n"]) for e in log] == [(3, 7), (4, 7), (5, 2)]  # 12 + 4 x 7 + 2 = 42
    # a different seed picks differently
    other, _, _ = active_sampling(robot, tip, ActiveSpec(42, 7, **{**kw, "seed": 4}), fit_ensemble=fit)
    assert not np.array_equal(other, full_u)


def test_pick_apart():
    x = np.array([[0.0], [0.01], [0.5], [1.0]])
    spread = np.array([1.0, 0.99, 0.5, 0.1])
    assert pick_apart(x, spread, np.empty((0, 1)), 2, radius=0.2).tolist() == [0, 2]  # not 1: too close to 0
    assert pick_apart(x, spread, np.empty((0, 1)), 2, radius=1e-3).tolist() == [0, 1]  # a tiny radius: by spread
    assert pick_apart(x, spread, np.array([[0.0]]), 1, radius=0.2).tolist() == [2]  # 0 is measured already
    assert sorted(pick_apart(x, np.zeros(4), np.empty((0, 1)), 4, 0.2).tolist()) == [0, 1, 2, 3]  # never twice
    with pytest.raises(InputError, match="cannot pick 5"):
        pick_apart(x, spread, np.empty((0, 1)), 5, 0.2)


def test_defaults_and_bad_arguments(robot):
    assert default_initial(200) == 100 and default_initial(13) == 6 and default_initial(1) == 1
    calls = []
    u, _, log = active_sampling(robot, tip, ActiveSpec(61, 8), fit_ensemble=corner_fit(robot, calls))
    assert [e["n"] for e in log] == [30] + [8] * 3 + [7] and calls[0][1:5] == ((20, 20), 5, calls[0][3], None)
    fit = corner_fit(robot, [])
    for kwargs, words in [
        (dict(n_total=0, batch=2), "n_total >= 1"),
        (dict(n_total=10, batch=0), "batch >= 1"),
        (dict(n_total=10, batch=2, n_initial=11), "exceeds n_total"),
        (dict(n_total=10, batch=2, k=1), "k >= 2"),
        (dict(n_total=10, batch=2, seed=-1), "seed >= 0"),
        (dict(n_total=10, batch=2, pool_size=1), "pool_size >= 2"),
        (dict(n_total=10, batch=2, radius=0.0), "radius"),
        (dict(n_total=10, batch=2, density_radius=-1.0), "density_radius"),
    ]:
        with pytest.raises(InputError, match=words):
            ActiveSpec(**kwargs)
    for done, words in [
        (dict(u_done=np.full((2, 3), 3.0), y_done=np.zeros((2, 3))), "safe commands"),
        (dict(u_done=np.zeros((2, 3)), y_done=np.zeros((1, 3))), "same number"),
    ]:
        with pytest.raises(InputError, match=words):
            active_sampling(robot, tip, ActiveSpec(10, 2), fit_ensemble=fit, **done)
    with pytest.raises(InputError, match="ActiveSpec"):
        active_sampling(robot, tip, 10, fit_ensemble=fit)
    with pytest.raises(LabRuntimeError, match="finite tips"):
        active_sampling(robot, lambda u: tip(u)[:, :2], ActiveSpec(10, 2), fit_ensemble=fit)


def test_the_density_keeps_picks_off_the_boundary(robot):
    """Where the members disagree equally, picks go where a sample informs the most volume."""

    class Flat(CornerEnsemble):
        def predict_with_std(self, u_pool):
            return np.zeros((len(u_pool), 3)), np.full((len(u_pool), 3), 1e-3)

    def to_boundary(u):  # distance (u / u_max) to the nearest face of the box or of the safety rule
        x = u / robot.u_max_rad
        plane = (robot.safety_limits[0].max_sum_over_u_max - x.sum(axis=1)) / np.sqrt(3)
        return np.minimum(np.minimum(x, 1 - x).min(axis=1), plane)

    def picks(density_radius):
        u, _, _ = active_sampling(
            robot,
            tip,
            ActiveSpec(60, 10, n_initial=10, density_radius=density_radius),
            fit_ensemble=lambda u, y, **kw: Flat(robot, u, y, 0),
        )
        return u[10:]

    inside, spread_only = to_boundary(picks(0.3)), to_boundary(picks(None))
    assert inside.mean() > 2 * spread_only.mean()  # spread alone fills the boundary first (maximin-like)
    x = np.array([[0.5, 0.5, 0.5], [0.0, 0.0, 0.0], [0.55, 0.5, 0.5]])
    assert pool_density(x, 0.2).tolist() == [1.0, 0.5, 1.0]
