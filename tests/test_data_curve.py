"""Error against N per sampling strategy: the rows, the common held-out set, grid
sizes, noise on emulated samples, resuming, the summaries and the command's refusals."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from lab.cli import main
from lab.data.designs import DESIGNS, grid_commands
from lab.description import load_robot
from lab.rig.twin import quasi_static_tips
from lab.studies.data_curve import draw_and_measure, heldout_set, make_body
from lab.studies.data_curve_plan import PAPER_GRID_N, grid_levels_for, hours_saved, plan_rows, smallest_n
from lab.studies.data_curve_run import COLUMNS, read_data_curve

COARSE = ["--n-rings", "1", "--n-axial", "4"]
FAST = ["--heldout", "12", "--epochs", "8", "--n-points", "4", "--jobs", "1", "--samples-per-hour", "300"]
STRATS = ["grid", "sobol", "maximin", "random"] + (["lhs"] if "lhs" in DESIGNS else [])


@pytest.fixture(scope="module")
def robot():
    return load_robot("three-cable")


def _args(out, strategies=STRATS, ns=("8", "16"), extra=()):
    return ["data-curve", "--rig", "sim", *COARSE, *FAST, "--strategies", *strategies, "--ns", *ns, *extra,
            "--out", str(out)]  # fmt: skip


def test_grid_levels_nearest_each_n_and_the_paper_grid(robot):
    assert grid_levels_for(robot, [25, 50, 100, 200, 308]) == {3: 23, 4: 54, 5: 105, 6: 181, 7: PAPER_GRID_N}
    assert grid_levels_for(robot, [1, 24], levels=[7, 3]) == {3: 23, 7: 308}
    assert grid_levels_for(robot, [300, 310]) == {7: 308}  # one grid for both Ns
    plan = plan_rows(robot, ["random", "grid"], [20, 5], None)
    assert plan == [("random", 5, None), ("random", 20, None), ("grid", 7, 2), ("grid", 23, 3)]
    with pytest.raises(ValueError, match="at least 2 levels"):
        grid_levels_for(robot, [5], levels=[1])


def test_command_writes_rows_on_one_heldout_set(tmp_path, robot):
    out = tmp_path / "c.csv"
    assert main(_args(out)) == 0
    rows = read_data_curve(out)
    assert list(rows[0]) == list(COLUMNS)
    assert [(r["strategy"], r["n"]) for r in rows] == [
        ("grid", 7),
        ("grid", 23),
        *[(s, n) for s in STRATS[1:] for n in (8, 16)],
    ]
    # the grids' N is their safe count, recorded with the levels
    assert [(r["grid_levels"], r["n"]) for r in rows[:2]] == [(2, len(grid_commands(robot, 2))), (3, 23)]
    assert len({r["heldout_id"] for r in rows}) == 1
    meta = json.loads(Path(f"{out}.json").read_text())
    assert meta["heldout"]["id"] == rows[0]["heldout_id"] and meta["settings"]["samples_per_hour"] == 300
    for r in rows:
        assert r["rig"] == "FEM" and r["robot"] == "three-cable" and r["model"] == "mlp"
        assert r["capture_h"] == pytest.approx(r["n"] / 300)
        assert 0 < r["model_error_m"] < 0.1 and 0 < r["tracking_mean_m"] < 0.1
        assert r["tracking_mean_m"] == pytest.approx(np.mean([r["circle_m"], r["square_m"], r["rose_m"]]))
    # more data helps on this scale (8 -> 23 grid samples, mm-level differences)
    assert rows[1]["model_error_m"] < rows[0]["model_error_m"]


def test_heldout_set_is_random_common_and_noise_free(robot):
    body, label, noise = make_body(robot, "twin:random:0", n_rings=1, n_axial=4)
    assert label == "emulated as-built robot" and noise > 0
    u, tips, fid = heldout_set(body, 10, seed=1)
    u2, _, fid2 = heldout_set(make_body(robot, "sim", n_rings=1, n_axial=4)[0], 10, seed=1)
    np.testing.assert_array_equal(u, u2)  # the same commands whatever the rig
    assert fid == fid2 and heldout_set(body, 10, seed=2)[2] != fid
    np.testing.assert_array_equal(tips, quasi_static_tips(body, u))  # settled, no noise
    lattice = grid_commands(robot, 7) / robot.u_max_rad
    d = np.min(np.linalg.norm(u[:, None] / robot.u_max_rad - lattice[None], axis=2), axis=1)
    assert d.min() > 1e-6  # never lattice points


def test_emulated_samples_carry_the_robots_noise_and_are_reproducible(robot):
    body, _, noise = make_body(robot, "twin:random:0", n_rings=1, n_axial=4)
    u, y = draw_and_measure(body, "sobol", 40, None, noise_sigma_m=noise, seed=0, opts={})
    err = y - quasi_static_tips(body, u)
    assert 0.5 * noise < err.std() < 1.5 * noise
    u2, y2 = draw_and_measure(body, "sobol", 40, None, noise_sigma_m=noise, seed=0, opts={})
    np.testing.assert_array_equal(y, y2)
    _, y3 = draw_and_measure(body, "sobol", 40, None, noise_sigma_m=noise, seed=1, opts={})
    assert not np.allclose(y, y3)


def test_resume_measures_only_missing_rows_and_matches_a_full_run(tmp_path, capsys):
    out, full = tmp_path / "resumed.csv", tmp_path / "full.csv"
    assert main(_args(out, ["sobol", "grid"], ["8"])) == 0  # "killed" after these rows
    first = out.read_text().splitlines()[1:]
    assert main(_args(out, ["grid", "sobol", "random"], ["8", "16"])) == 0
    assert "2 already in" in capsys.readouterr().err
    lines = out.read_text().splitlines()[1:]
    assert lines[: len(first)] == first  # kept as they were, not recomputed
    before = out.read_bytes()
    assert main(_args(out, ["grid", "sobol", "random"], ["8", "16"])) == 0  # nothing left to do
    assert out.read_bytes() == before and "0 rows to measure" in capsys.readouterr().err
    assert len(json.loads(Path(f"{out}.json").read_text())["commands"]) == 2
    # another seed: new designs, noise and weights on the same held-out set; seed 0 kept
    assert main([*_args(out, ["sobol"], ["8"]), "--seeds", "0", "1"]) == 0
    again = read_data_curve(out)
    assert out.read_text().splitlines()[1:-1] == lines and [(r["seed"], r["n"]) for r in again[-1:]] == [(1, 8)]
    s0 = next(r for r in again if (r["strategy"], r["n"], r["seed"]) == ("sobol", 8, 0))
    assert again[-1]["model_error_m"] != s0["model_error_m"] and again[-1]["heldout_id"] == s0["heldout_id"]
    assert main(_args(full, ["grid", "sobol", "random"], ["8", "16"])) == 0
    key = lambda r: (r["strategy"], r["n"])  # noqa: E731
    got = {key(r): r for r in read_data_curve(out) if r["seed"] == 0}
    want = {key(r): r for r in read_data_curve(full)}
    assert got.keys() == want.keys() and len(got) == 6
    for k, r in want.items():  # each row depends on its own (strategy, N) only
        assert got[k]["model_error_m"] == pytest.approx(r["model_error_m"], rel=1e-4), k
        assert got[k]["tracking_mean_m"] == pytest.approx(r["tracking_mean_m"], rel=1e-3), k


def test_model_error_only_and_refusals(tmp_path, capsys):
    out = tmp_path / "m.csv"
    assert main(_args(out, ["random"], ["8"], ["--no-tracking"])) == 0
    (row,) = read_data_curve(out)
    assert row["model_error_m"] > 0 and np.isnan(row["tracking_mean_m"]) and np.isnan(row["rose_m"])
    # resuming with other settings would mix two studies in one file
    assert main(_args(out, ["random"], ["8"])) == 2
    assert "other settings (tracking)" in capsys.readouterr().err
    assert main(_args(tmp_path / "x.csv", ["grid", "magic"])) == 2
    assert "unknown sampling strategy ['magic']" in capsys.readouterr().err
    assert main([*_args(tmp_path / "y.csv", ["random"]), "--rig", "hardware:rig.toml"]) == 2
    assert main(_args(tmp_path / "z.csv", ["random"], ["0"])) == 2
    assert main([*_args(tmp_path / "w.csv", ["random"]), "--model", "nonsense"]) == 2
    assert "unknown model 'nonsense'" in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()


def test_smallest_n_and_hours_saved():
    rows = [
        {"strategy": s, "n": n, "model_error_m": e, "rig_spec": rig}
        for s, n, e, rig in [
            ("grid", 23, 2e-3, "a"),
            ("grid", 308, 0.4e-3, "a"),
            ("sobol", 25, 1e-3, "a"),
            ("sobol", 50, 0.6e-3, "a"),
            ("sobol", 50, 0.3e-3, "b"),  # two robots average to 0.45 mm at N = 50
            ("sobol", 100, 0.2e-3, "a"),
            ("random", 25, 0.9e-3, "a"),
        ]
    ]
    got = smallest_n(rows, "model_error_m", 0.5e-3)
    assert got["grid"] == (308, pytest.approx(0.4e-3))
    assert got["sobol"] == (50, pytest.approx(0.45e-3))
    assert got["random"] is None
    assert hours_saved(50, 290.0) == pytest.approx(258 / 290.0)
    assert hours_saved(PAPER_GRID_N, 290.0) == 0


def test_active_rows_sample_in_batches_and_resume_unchanged(tmp_path, capsys):
    pytest.importorskip("lab.learn.active")
    out = tmp_path / "a.csv"
    extra = ["--batch", "4", "--n-initial", "6", "--no-tracking"]
    assert main(_args(out, ["active"], ["6", "14"], extra)) == 0
    rows = read_data_curve(out)
    assert [(r["strategy"], r["n"]) for r in rows] == [("active", 6), ("active", 14)]
    assert rows[1]["model_error_m"] > 0 and rows[1]["design_s"] > rows[0]["design_s"]  # ensembles trained
    before = out.read_bytes()
    assert main(_args(out, ["active"], ["6", "14"], extra)) == 0 and out.read_bytes() == before
    assert main(_args(out, ["active"], ["6", "14"], ["--batch", "5", "--n-initial", "6", "--no-tracking"])) == 2
    assert "other settings (batch)" in capsys.readouterr().err


def test_active_measures_exactly_n_with_the_robots_noise(robot):
    pytest.importorskip("lab.learn.active")
    body, _, noise = make_body(robot, "twin:random:0", n_rings=1, n_axial=4)
    opts = {"batch": 3, "n_initial": 6, "hidden": (4,), "epochs": 3}
    u, y = draw_and_measure(body, "active", 12, None, noise_sigma_m=noise, seed=0, opts=opts)
    assert u.shape == (12, 3) and np.all(robot.is_safe(u))
    err = y - quasi_static_tips(body, u)
    assert 0 < np.abs(err).max() < 6 * noise
    u2, y2 = draw_and_measure(body, "active", 12, None, noise_sigma_m=noise, seed=0, opts=opts)
    np.testing.assert_array_equal(u, u2)
    np.testing.assert_array_equal(y, y2)


def test_other_models_and_algorithms_fit_from_the_registry(tmp_path):
    pytest.importorskip("lab.learn.models")
    out = tmp_path / "g.csv"
    assert main(_args(out, ["sobol"], ["16"], ["--model", "gpr", "--no-tracking"])) == 0
    (gpr,) = read_data_curve(out)
    out2 = tmp_path / "b.csv"
    assert main(_args(out2, ["sobol"], ["16"], ["--algorithm", "br", "--no-tracking"])) == 0
    (br,) = read_data_curve(out2)
    assert gpr["model"] == "gpr" and 0 < gpr["model_error_m"] < 0.05 and 0 < br["model_error_m"] < 0.05
    assert "algorithm='br'" in json.loads(Path(f"{out2}.json").read_text())["model_recipe"]
    assert main(_args(tmp_path / "c.csv", ["sobol"], ["16"], ["--algorithm", "magic"])) == 2


def test_any_robot_six_cables_model_error_only(tmp_path):
    six = load_robot("six-cable")
    out = tmp_path / "six.csv"
    argv = ["data-curve", "--robot", "six-cable", "--rig", "sim", *COARSE, *FAST, "--no-tracking",
            "--strategies", "grid", "sobol", "--ns", "30", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    grid, sobol = read_data_curve(out)
    assert (grid["robot"], grid["grid_levels"], grid["n"]) == ("six-cable", 2, len(grid_commands(six, 2)))
    assert sobol["n"] == 30 and 0 < sobol["model_error_m"] < 0.1 and np.isnan(sobol["tracking_mean_m"])


def test_flags_keep_their_names_and_defaults():
    from lab.cli import build_parser
    from lab.fem.bodies.mesh_spec import MeshSpec
    from lab.studies.data_curve_spec import DEFAULT_NS, DEFAULT_RATE_FROM, DataCurveSpec, default_strategies

    (sub,) = [a for a in build_parser()._actions if a.dest == "command"]
    flags = {s for a in sub.choices["data-curve"]._actions for s in a.option_strings}
    assert flags >= {"--robot", "--rig", "--strategies", "--ns", "--grid-levels", "--model", "--hidden", "--epochs",
                     "--algorithm", "--heldout", "--seeds", "--heldout-seed", "--batch", "--n-initial", "--n-points",
                     "--no-tracking", "--n-rings", "--n-axial", "--samples-per-hour", "--rate-from", "--jobs",
                     "--out"}  # fmt: skip
    spec = DataCurveSpec()
    assert (spec.robot, spec.rig, spec.ns, spec.model, spec.hidden, spec.algorithm) == (
        "three-cable", "sim", DEFAULT_NS, "mlp", (20, 20), "lm"
    )  # fmt: skip
    assert (spec.heldout, spec.seeds, spec.heldout_seed, spec.batch, spec.n_points, spec.tracking) == (
        200, (0,), 1, 25, 24, True
    )  # fmt: skip
    assert spec.strategies == default_strategies() and "active" not in spec.strategies
    assert spec.rate_from == DEFAULT_RATE_FROM and spec.mesh == MeshSpec() and spec.epochs is None
    assert DataCurveSpec(rig="twin:random:3").rig_spec.family_seed == 3


@pytest.mark.parametrize(
    "fields, words",
    [
        ({"ns": (0,)}, "DataCurveSpec.ns must be integers >= 1"),
        ({"ns": (10**9,)}, "DataCurveSpec.ns must be at most 100000"),
        ({"strategies": ("maximin",), "ns": (5000,)}, "a maximin design takes at most 2000"),
        ({"seeds": (-1,)}, "DataCurveSpec.seeds must be integers >= 0"),
        ({"seeds": tuple(range(1001))}, "at most 1000 seeds"),
        ({"strategies": ("sobol", "random"), "ns": tuple(range(1, 5002))}, "at most 10,000"),
        ({"heldout": 10**7}, "DataCurveSpec.heldout must be at most 100000"),
        ({"n_points": 1}, "DataCurveSpec.n_points must be an integer >= 2"),
        ({"hidden": (20, 0)}, "DataCurveSpec.hidden must be widths >= 1"),
        ({"algorithm": "magic"}, "DataCurveSpec.algorithm must be one of"),
        ({"model": "inverse-mlp"}, "unknown model 'inverse-mlp'"),
        ({"samples_per_hour": 0.0}, "DataCurveSpec.samples_per_hour must be finite and > 0"),
        ({"strategies": ("active",), "batch": 5000, "ns": (6000,)}, "DataCurveSpec.batch must be at most 4096"),
        ({"rig": "hardware:rig.toml"}, "measures through a body's quasi-static map"),
        ({"grid_levels": (1,)}, "DataCurveSpec.grid_levels must be integers >= 2"),
    ],
)
def test_spec_refuses_bad_settings_naming_the_flag(fields, words):
    from lab.studies.data_curve_spec import DataCurveSpec

    with pytest.raises(ValueError, match=re.escape(words)):
        DataCurveSpec(**fields)


def test_unreadable_results_files_are_refused_naming_the_file(tmp_path):
    from lab.errors import InputError

    out = tmp_path / "c.csv"
    row = "three-cable,FEM,sim,random,8,,0,mlp,0.02,nan,nan,nan,nan,0.1,0.1,0.02,ab"
    out.write_text(",".join(COLUMNS) + "\n" + row + "\n")
    assert read_data_curve(out)[0]["n"] == 8
    out.write_text(",".join(COLUMNS) + "\n" + row.replace(",mlp,0.02,", ",mlp,x,") + "\n")
    with pytest.raises(InputError, match=r"c.csv: line 2: model_error_m 'x' is not a number"):
        read_data_curve(out)
    out.write_text(",".join(COLUMNS) + "\n" + row.rsplit(",", 3)[0] + "\n")
    with pytest.raises(InputError, match="line 2 does not have the 17 columns"):
        read_data_curve(out)
    out.write_text(",".join(COLUMNS) + "\n" + row + "\n")
    Path(f"{out}.json").write_text('{"settings": [1]}')
    with pytest.raises(InputError, match=r"c.csv.json: the sidecar of .* must be a JSON object with settings"):
        read_data_curve(out)
