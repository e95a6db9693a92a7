"""Dataset diagnostics (lab.data.repeatability, lab.data.diagnostics) and ``python -m lab inspect``.

Synthetic data with known parts: ``y = f(u) + N(0, sigma^2 I)`` with exact revisits and
near pairs, plus (per test) a hysteresis term in the previous command, a linear drift in
the row index, or outlier rows. Each diagnostic must find what was put in, and report
(near) nothing where nothing was.
"""

import json

import numpy as np
import pytest

from lab.data import InspectSpec, inspect_dataset, neighbour_pairs, read_dataset, repeatability_floor, write_dataset
from lab.errors import InputError

SIGMA_M = 0.002  # per axis: the floor is sqrt(3) sigma
FAST = InspectSpec(bootstrap=50)
#: the previous-command coefficient (tip m per unit command) of the hysteresis tests
H = np.array([[0.02, 0.0, 0.01], [0.0, -0.015, 0.0], [0.01, 0.0, 0.02]])


def f_true(u):
    """A smooth map of 3 commands in [-1, 1] to a tip (m), about 5 cm of motion."""
    return 0.05 * np.column_stack(
        [
            np.sin(1.3 * u[:, 0]) + 0.5 * u[:, 1] * u[:, 2],
            np.cos(1.1 * u[:, 1]) - 0.3 * u[:, 0] ** 2,
            0.7 * u[:, 2] + 0.4 * np.sin(u[:, 0] + u[:, 1]),
        ]
    )


def synthetic(seed, n=600, hysteresis=0.0, drift_m_per_1000=0.0, n_outliers=0):
    """(u, y, outlier rows): random commands, 80 exact revisits and 80 near pairs (0.01 apart)
    in the second half; ``y = f(u) + noise + hysteresis H (u_prev - u) + drift t``."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (n, 3))
    late = np.arange(n // 2, n)
    later, source = rng.choice(late, 160, replace=False), rng.choice(n // 2, 160, replace=False)
    u[later] = u[source]
    u[later[80:]] += rng.normal(0, 0.01, (80, 3))
    previous = np.vstack([u[:1], u[:-1]])
    drift = drift_m_per_1000 * np.arange(n)[:, None] / 1000 * np.array([0.6, 0.0, 0.8])
    y = f_true(u) + rng.normal(0, SIGMA_M, (n, 3)) + hysteresis * (previous - u) @ H.T + drift
    out = np.sort(rng.choice(n, n_outliers, replace=False))
    y[out] += rng.choice([-1, 1], (n_outliers, 3)) * 0.03
    return u, y, out


@pytest.fixture(scope="module")
def plain():
    u, y, _ = synthetic(0)
    return u, y, inspect_dataset(u, y, None, FAST)


def test_floor_recovers_the_noise_rms(plain):
    """A perfect static model is off by sqrt(3) sigma RMS (3-D); the floor finds it within 10 %."""
    _, _, report = plain
    floor, truth = report["floor"], np.sqrt(3) * SIGMA_M
    assert floor["floor_m"] == pytest.approx(truth, rel=0.10)
    lo, hi = floor["interval_m"]
    assert lo < floor["floor_m"] < hi and hi - lo < 0.3 * truth
    assert floor["revisits"]["floor_m"] == pytest.approx(truth, rel=0.15)  # from d = 0 alone
    assert floor["n_exact_pairs"] == 80 and floor["revisits"]["n_pairs"] == floor["n_exact_pairs"]
    np.testing.assert_allclose(floor["per_axis_m"], SIGMA_M, rtol=0.2)
    assert np.sum(np.square(floor["per_axis_m"])) == pytest.approx(floor["floor_m"] ** 2, rel=0.05)


@pytest.mark.parametrize("seed", [1, 2])
def test_floor_on_other_draws(seed):
    u, y, _ = synthetic(seed)
    assert repeatability_floor(u, y, np.zeros(len(u), int), bootstrap=5)["floor_m"] == pytest.approx(
        np.sqrt(3) * SIGMA_M, rel=0.12
    )


def test_exact_revisits_and_pairs():
    u = np.array([[0, 0], [1, 0], [0, 0], [0.5, 1], [0, 0], [1, 1]], float)
    pairs, dist, exact = neighbour_pairs(u, 1)
    assert {tuple(p) for p in pairs[exact]} == {(0, 2), (0, 4), (2, 4)}  # every pair of the three revisits
    assert np.all(dist[exact] == 0) and np.all(dist[~exact] > 0)
    assert np.all(pairs[:, 0] < pairs[:, 1]) and len({tuple(p) for p in pairs}) == len(pairs)


def test_sequences_split_the_pairs():
    """A second session shifted by 1 cm: pairs across sessions see it, pairs within do not."""
    u, y, _ = synthetic(3)
    seq = (np.arange(len(u)) >= len(u) // 2).astype(int)
    y = y + 0.01 * seq[:, None] * np.array([1.0, 0.0, 0.0])
    floor = repeatability_floor(u, y, seq, bootstrap=5)
    assert floor["same_sequence"]["floor_m"] == pytest.approx(np.sqrt(3) * SIGMA_M, rel=0.25)
    # the offset adds 1 cm between the two rows of a cross pair: (0.01^2 / 2) to the floor's square
    expected = np.sqrt(3 * SIGMA_M**2 + 0.01**2 / 2)
    assert floor["cross_sequence"]["floor_m"] == pytest.approx(expected, rel=0.25)


def test_hysteresis_found_and_its_slope(plain):
    u, y, _ = synthetic(0, hysteresis=1.0)
    h = inspect_dataset(u, y, None, FAST)["hysteresis"]
    assert h["fraction_explained"] > 0.5 and h["p_value"] < 0.05
    assert h["slope_m_per_unit"] == pytest.approx(np.linalg.norm(H, 2), rel=0.1)
    np.testing.assert_allclose(h["per_motor_m_per_unit"], np.linalg.norm(H, axis=0), atol=0.003)
    without = plain[2]["hysteresis"]
    assert abs(without["fraction_explained"]) < 0.01 and without["slope_m_per_unit"] < 0.1 * np.linalg.norm(H, 2)


def test_drift_found_and_absent(plain):
    u, y, _ = synthetic(0, drift_m_per_1000=0.02)
    d = inspect_dataset(u, y, None, FAST)["drift"]
    assert d["rate_m_per_1000_rows"] == pytest.approx(0.02, rel=0.15)
    assert d["interval"][0] > 0.01
    np.testing.assert_allclose(d["velocity_m_per_1000_rows"], [0.012, 0.0, 0.016], atol=0.004)
    assert d["row_index_r2_from_command"] < 0.1  # random commands: time is not confounded
    assert plain[2]["drift"]["rate_m_per_1000_rows"] < 0.004


def test_outliers_found(plain):
    u, y, out = synthetic(2, n_outliers=5)
    o = inspect_dataset(u, y, None, FAST)["outliers"]
    assert set(out) <= set(o["rows"]) and o["count"] <= len(out) + 2
    assert all(r > o["threshold_m"] for r in o["residual_m"])
    assert plain[2]["outliers"]["count"] <= 3


def test_grid_without_spread_says_why():
    """Every pair at one distance (a full grid, one neighbour): no line, no floor, a reason."""
    g = np.linspace(-1, 1, 4)
    u = np.array(np.meshgrid(g, g)).reshape(2, -1).T
    y = np.column_stack([u, u[:, :1] ** 2]) * 0.01
    floor = inspect_dataset(u, y, None, InspectSpec(neighbours=1, bootstrap=5))["floor"]
    assert floor["floor_m"] is None and "one command distance" in floor["reason"]


def test_report_is_json_and_checks_its_input(plain):
    u, y, report = plain
    assert report["format_version"] == 1 and report["kind"] == "lab.inspect" and report["n_rows"] == len(u)
    json.dumps(report, allow_nan=False)
    bad = y.copy()
    bad[7, 1] = np.nan
    with pytest.raises(InputError, match="row 7"):
        inspect_dataset(u, bad)
    with pytest.raises(InputError, match="metres"):
        inspect_dataset(u, y * 1000)
    with pytest.raises(InputError, match="ascending"):
        inspect_dataset(u, y, np.r_[np.ones(10, int), np.zeros(len(u) - 10, int)])
    with pytest.raises(InputError, match="InspectSpec.neighbours"):
        InspectSpec(neighbours=51)


def test_cli_writes_the_report(tmp_path, capsys):
    from lab.cli import main

    u, y, _ = synthetic(4, n=400, hysteresis=1.0)
    data = tmp_path / "d.csv"
    write_dataset(data, u, y, {"sequence_starts": [0, 150, 300], "units": {"u": "effort", "xyz": "m"}})
    before = data.read_bytes()
    assert main(["inspect", str(data), "--out", str(tmp_path / "r.json"), "--bootstrap", "20"]) == 0
    printed = capsys.readouterr().out
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["n_sequences"] == 3 and report["dataset"]["u_unit"] == "effort"
    assert report["spec"]["bootstrap"] == 20 and report["command"].startswith("python -m lab inspect")
    assert f"{1e3 * report['floor']['floor_m']:.1f} mm" in printed and "hysteresis" in printed
    assert data.read_bytes() == before and read_dataset(data)[2]["sequence_starts"] == [0, 150, 300]


def test_figure_draws_a_report(plain, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from lab.viz import plot_diagnostics

    fig, axes = plot_diagnostics(plain[2])
    assert axes.shape == (2, 2) and "floor" in axes[0, 0].get_title()
    fig.savefig(tmp_path / "f.png", dpi=40)
    import matplotlib.pyplot as plt

    plt.close(fig)
