"""The capture-rate study (lab.studies.capture_rate) and its figure (lab.viz.capture_rate)."""

import json

import matplotlib
import numpy as np
import pytest

from lab.errors import InputError
from lab.studies.capture_rate import COLUMNS, capture_rate_study, read_capture_rate, write_capture_rate
from lab.viz import plot_capture_rate

matplotlib.use("Agg")


@pytest.fixture(scope="module")
def rows(three_cable):
    return capture_rate_study(
        three_cable, ("shipped",), n_samples=14, mesh={"n_rings": 2, "n_axial": 8}, predict_tols_m=(1.5e-4, 4e-4)
    )


def test_study_rows_compare_protocols_on_the_same_commands(rows):
    assert [(r["protocol"], r["tol_m"]) for r in rows] == [("wait", 1e-4), ("predictive", 1.5e-4), ("predictive", 4e-4)]
    wait, pred = rows[0], rows[1]
    assert set(rows[0]) == set(COLUMNS) and all(r["n"] == 14 for r in rows)
    # the waiting protocol has no learning phase: both rate columns are the same
    assert wait["rate_after_learning_per_hour"] == wait["rate_per_hour"] and np.isnan(wait["tau_fast_s"])
    assert pred["rate_after_learning_per_hour"] > 2.5 * wait["rate_per_hour"]
    assert pred["mean_error_after_learning_m"] < 3e-4 and pred["mean_pred_std_m"] <= 1.5e-4
    assert pred["tau_slow_s"] == pytest.approx(pred["true_tau_slow_s"], rel=0.1)


def test_table_round_trip_and_figure(rows, tmp_path):
    path = tmp_path / "rate.csv"
    write_capture_rate(path, rows, "python benchmarks/bench_capture.py --n 14")
    back = read_capture_rate(path)
    assert [r["protocol"] for r in back] == [r["protocol"] for r in rows]
    assert back[1]["rate_per_hour"] == pytest.approx(rows[1]["rate_per_hour"])
    assert json.loads((tmp_path / "rate.csv.json").read_text())["command"].endswith("--n 14")
    ax = plot_capture_rate(back + [{**back[1], "robot": "random:1"}])
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("predictive, shipped" in s for s in labels) and any("family" in s for s in labels)
    assert len(ax.lines[1].get_xdata()) == 2  # the predictive sweep: two tolerances, one line
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n")
    with pytest.raises(InputError, match="not a capture-rate table"):
        read_capture_rate(tmp_path / "bad.csv")
