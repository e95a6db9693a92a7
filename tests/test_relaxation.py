"""The relaxation filter (lab.dynamics.relaxation) and its fits (lab.dynamics.relaxation_fit)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from lab.dynamics.relaxation import DynamicsFileError, Relaxation, load_relaxation
from lab.dynamics.relaxation_fit import Segment, Stream, fit_exponentials, fit_stream, input_knots
from lab.errors import InputError

RELAX = Relaxation([0.4, 2.5], [0.7, 0.3])


def test_fit_recovers_a_known_two_exponential_signal():
    """Three noisy step responses sharing tau = (0.35, 3.1) s: the shared time constants,
    the final values and the amplitudes come back; one exponential cannot fit them."""
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 12.0, 0.1)
    truth_inf = rng.normal(0, 0.03, (3, 3))
    truth_amp = rng.normal(0, 0.01, (3, 2, 3))
    responses = []
    for r in range(3):
        y = truth_inf[r] + np.exp(-t[:, None] / 0.35) * truth_amp[r, 0] + np.exp(-t[:, None] / 3.1) * truth_amp[r, 1]
        responses.append((t, y + rng.normal(0, 2e-5, y.shape)))
    tau, y_inf, amp, rms = fit_exponentials(responses)
    assert tau == pytest.approx([0.35, 3.1], rel=0.03)
    assert np.abs(y_inf - truth_inf).max() < 2e-4
    assert np.abs(amp - truth_amp).max() < 5e-4
    assert rms < 3e-5
    assert fit_exponentials(responses, n_modes=1)[3] > 5 * rms


def test_response_matches_an_ode_solver_through_ramps_and_holds():
    """Exact piecewise-linear integration == solve_ivp of tau z' = p_eq - z on a ramp-hold-step input."""
    tk = np.array([0.0, 1.0, 3.0, 3.0, 3.4])
    pk = np.array([[0.0, 1.0], [1.0, 0.0], [1.0, 0.0], [-0.5, 0.2], [0.3, 0.3]])
    te = np.linspace(0.0, 9.0, 37)

    def rhs(t, z):
        p = np.array([np.interp(t, tk, pk[:, d]) for d in range(2)]) if t < 3.0 else None
        if t >= 3.0:
            p = np.array([np.interp(t, tk[3:], pk[3:, d]) for d in range(2)])
        return ((p[None, :] - z.reshape(2, 2)) / RELAX.tau_s[:, None]).ravel()

    z0 = np.repeat(pk[:1], 2, axis=0).ravel()
    sol = solve_ivp(rhs, (0, 9), z0, t_eval=te, rtol=1e-10, atol=1e-12, max_step=0.01)
    expected = np.einsum("k,kdn->nd", RELAX.weight, sol.y.reshape(2, 2, -1))
    assert np.abs(RELAX.response(tk, pk, te) - expected).max() < 1e-6
    # a step covers 1 - sum w exp(-t/tau) of its size
    assert np.allclose(RELAX.response([0, 0], [[0.0], [1.0]], te)[:, 0], RELAX.step(te), atol=1e-12)


def test_interval_is_smooth_for_tiny_steps():
    """Twenty short intervals and one long one give the same state (the expm1 form)."""
    z = np.zeros(2)
    for i in range(20):
        d, ga, gb = RELAX.interval(1e-9, i / 20, (i + 1) / 20)
        z = d * z + ga * 0.0 + gb * 1.0
    d, ga, gb = RELAX.interval(20e-9, 0.0, 1.0)
    assert np.allclose(z, gb, rtol=1e-6)
    with pytest.raises(InputError, match="backwards"):
        RELAX.interval(-1.0)


def _synthetic_stream(relax, n_samples=8, noise_m=1.5e-4 / 12**0.5, seed=0):
    """A capture-like stream: reset, release, target and a hold per sample."""
    rng = np.random.default_rng(seed)
    eq = {"initial": np.zeros(3), "rest": np.array([0.001, 0.0, -0.001])}
    segments, t = [], 0.0
    for i in range(n_samples):
        eq[f"reset{i}"] = np.array([0.01, 0.0, 0.02]) + rng.normal(0, 1e-3, 3)
        eq[f"s{i}"] = rng.normal(0, 0.03, 3)
        for pose, ramp, hold in ((f"reset{i}", 0.5, 0.0), ("rest", 0.5, 0.0), (f"s{i}", rng.uniform(0.2, 1.5), 5.0)):
            segments.append(Segment(t, t + ramp, pose))
            t += ramp + hold
    times = np.arange(0.05, t, 0.1)
    stream = Stream(times, np.zeros((len(times), 3)), np.full(len(times), 12), segments)
    poses = stream.poses()
    tk, wk = input_knots(stream, poses)
    truth = relax.response(tk, wk @ np.array([eq[p] for p in poses]), times)
    stream.p_tip_W = truth + rng.normal(0, noise_m, truth.shape)
    return stream, eq


def test_stream_fit_recovers_time_constants_weights_equilibria_and_noise():
    stream, eq = _synthetic_stream(RELAX)
    relax, report = fit_stream(stream)
    assert relax.tau_s == pytest.approx(RELAX.tau_s, rel=0.03)
    assert relax.weight == pytest.approx(RELAX.weight, abs=0.01)
    assert relax.noise_sigma_m == pytest.approx(1.5e-4, rel=0.1)
    err = max(np.linalg.norm(report["equilibria"][p] - eq[p]) for p in eq if p.startswith("s"))
    assert err < 1e-4


def test_stream_fit_refuses_too_little_data():
    stream, _ = _synthetic_stream(RELAX, n_samples=1)
    short = Stream(stream.t_s[:5], stream.p_tip_W[:5], stream.n_valid[:5], stream.segments[:1])
    with pytest.raises(InputError, match="too little"):
        fit_stream(short)


def test_interrupted_move_starts_from_where_the_last_one_was():
    """A command sent halfway through a ramp starts its own ramp from the halfway equilibrium."""
    s = Stream(np.array([0.0]), np.zeros((1, 3)), np.ones(1), [Segment(0.0, 1.0, "a"), Segment(0.5, 1.5, "b")])
    tk, wk = input_knots(s, s.poses())
    assert tk.tolist() == [0.0, 0.5, 1.5]
    assert np.allclose(wk, [[1, 0, 0], [0.5, 0.5, 0], [0, 0, 1]])


def test_bad_relaxations_are_refused():
    with pytest.raises(InputError, match="positive"):
        Relaxation([0.4, -1.0], [0.5, 0.5])
    with pytest.raises(InputError, match="sum to 1"):
        Relaxation([0.4, 1.0], [0.5, 0.6])


def test_save_and_load_round_trip_and_bad_files(tmp_path):
    RELAX.save(tmp_path / "dyn.npz", robot="three-cable")
    back = load_relaxation(tmp_path / "dyn.npz")
    assert np.array_equal(back.tau_s, RELAX.tau_s) and np.array_equal(back.weight, RELAX.weight)
    np.savez(tmp_path / "other.npz", tau_s=[1.0], weight=[1.0], metadata='{"kind": "lab.mlp"}')
    with pytest.raises(DynamicsFileError, match="kind"):
        load_relaxation(tmp_path / "other.npz")
    (tmp_path / "junk.npz").write_text("not a zip")
    with pytest.raises(DynamicsFileError, match="junk.npz"):
        load_relaxation(tmp_path / "junk.npz")
    with pytest.raises(DynamicsFileError, match="no such"):
        load_relaxation(tmp_path / "missing.npz")
