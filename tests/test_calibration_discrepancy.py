"""``calibrate`` against model error: the chi-square test of the residual against the declared
noise, the Birge-inflated standard deviations, and their keys in the report (coarse mesh).

The robots are defects files written here: one exactly in the calibrator's model class (no
play, no eyelet shift along the body, no encoder rounding), and the same arm on a base
tilted by 5 deg, a defect ``calibrate`` has no parameter for.
"""

import json

import numpy as np
import pytest
from scipy.stats import chi2 as chi2_dist

from lab.asbuilt.arm import load_defects
from lab.cli import main
from lab.data.dataset import write_dataset
from lab.data.designs import design_commands
from lab.rig.twin import AsBuiltBody, quasi_static_tips
from lab.transfer import DISCREPANCY_QUANTILE, calibrate, model_check
from lab.transfer.recovery import true_theta

MESH = dict(n_rings=1, n_axial=6)
NOISE_M = 1e-4
N_SAMPLES = 10
N_FITS = 12
DEFECTS = """format_version = 1
robot = "three-cable"
[material]
softness = 0.8
gradient = 0.3
gradient_direction = [0.0, 0.6, -0.8]
[[cables]]
name = "top"
via_shift_m = [0.0, 0.0003, -0.0004]
slack_m = 0.001
play_m = 0.0
[[cables]]
name = "lower-left"
via_shift_m = [0.0, -0.0008, -0.0006]
slack_m = 0.003
play_m = 0.0
[[cables]]
name = "lower-right"
via_shift_m = [0.0, 0.0006, -0.0005]
slack_m = 0.002
play_m = 0.0
[lag]
tau_fast_s = 0.4
tau_slow_s = 2.5
slow_fraction = 0.3
[motors]
ticks_per_rev = 0
profile_velocity_rad_s = 2.0
[mocap]
frame_rate_hz = 120.0
noise_sigma_m = 0.0001
dropout_rate_hz = 0.0
dropout_max_frames = 1
"""
TILT = "[mount]\ntilt_deg = 5.0\ntilt_axis = [0.0, 1.0, 0.0]\n"


@pytest.fixture(scope="module")
def arms(three_cable, tmp_path_factory):
    """The commands, the settled tips without noise of the in-class arm and of the tilted one,
    and the in-class arm's defects."""
    folder = tmp_path_factory.mktemp("defects")
    (folder / "in-class.toml").write_text(DEFECTS)
    (folder / "tilted.toml").write_text(DEFECTS + TILT)
    u = design_commands(three_cable, N_SAMPLES, "maximin", 0)
    defects = {k: load_defects(folder / f"{k}.toml", three_cable) for k in ("in-class", "tilted")}
    tips = {k: quasi_static_tips(AsBuiltBody(three_cable, d, **MESH), u) for k, d in defects.items()}
    return u, tips, defects["in-class"]


def _noisy(y, seed):
    return y + NOISE_M * np.random.default_rng(seed).standard_normal(y.shape)


def test_model_check_numbers():
    # residuals of known size: RSS = n * 3 * (noise / 2)^2, so chi2 = 3n / 4 on 3n - p dof
    n, p, noise = 20, 6, 2e-4
    r = np.full((n, 3), noise / 2)
    c = model_check(r, noise, p)
    assert c["chi2"] == pytest.approx(3 * n / 4) and c["dof"] == 3 * n - p and c["p_eff"] == p
    assert c["rms_m"] == pytest.approx(np.sqrt(3) * noise / 2)
    assert c["expected_rms_m"] == pytest.approx(noise * np.sqrt((3 * n - p) / n))
    assert c["chi2_threshold"] == pytest.approx(chi2_dist.ppf(DISCREPANCY_QUANTILE, 3 * n - p))
    assert not c["model_discrepancy"] and c["std_inflation"] == 1.0 and c["birge_ratio"] < 1
    # just above and just below the threshold
    scale = np.sqrt(c["chi2_threshold"] / c["chi2"])
    assert model_check(r * scale * 1.001, noise, p)["model_discrepancy"]
    assert not model_check(r * scale * 0.999, noise, p)["model_discrepancy"]
    big = model_check(3 * r, noise, p, p_eff=4.5)
    assert big["dof"] == 3 * n - 4.5 and big["std_inflation"] == pytest.approx(np.sqrt(9 * 3 * n / 4 / (3 * n - 4.5)))


def test_in_class_arm_with_the_right_noise_is_not_flagged_and_its_intervals_cover(three_cable, arms):
    # N_FITS fits of the in-class arm, each with fresh noise of the declared size: no fit is
    # flagged, the mean reduced chi-square of N_FITS independent chi2(dof)/dof draws has
    # standard deviation sqrt(2 / (N_FITS dof)) (0.1 here): it must lie within 4 of them of 1
    # (dof = 3N instead of 3N - p_eff would give 0.6), and the 2-sigma intervals must hold the
    # true parameters about 95 % of the time (binomial over 144 intervals: 0.85 is > 5 sd
    # below; all 144 inside, likelier with stds too large, has probability 6e-4)
    u, tips, defects = arms
    fits = [calibrate(three_cable, u, _noisy(tips["in-class"], k), **MESH, noise_m=NOISE_M) for k in range(N_FITS)]
    checks = [f.check for f in fits]
    dof = checks[0]["dof"]
    assert 3 * N_SAMPLES - 12 < dof < 3 * N_SAMPLES - 11  # the data determine nearly all 12 parameters
    assert not any(c["model_discrepancy"] for c in checks)
    mean = np.mean([c["reduced_chi2"] for c in checks])
    assert abs(mean - 1) < 4 * np.sqrt(2 / (N_FITS * dof)), mean
    truth = true_theta(fits[0].layout, defects)
    inside = np.array([np.abs(f.theta - truth) <= 2 * f.std_raw for f in fits])
    assert 0.85 < inside.mean() < 1.0, inside.mean()
    for f, c in zip(fits, checks):  # the reported stds are the raw ones unless chi2 / dof > 1
        if c["reduced_chi2"] <= 1:
            assert np.allclose(f.std, f.std_raw, rtol=1e-9)
        assert np.all(f.std >= f.std_raw * (1 - 1e-9)) and np.all(f.std <= f.std_raw * c["std_inflation"] * 1.0001)


def test_tilted_base_is_flagged_and_its_stds_inflated(three_cable, arms, tmp_path, capsys):
    # 5 deg of tilt moves the tip ~17 mm; softness and eyelet shifts absorb most of it, but
    # what is left is far above the noise: the flag fires and the reported stds are the
    # inflated ones, larger than the raw ones by up to the Birge ratio
    u, tips, _ = arms
    res = calibrate(three_cable, u, _noisy(tips["tilted"], 0), **MESH, noise_m=NOISE_M)
    c = res.check
    assert res.converged and c["model_discrepancy"] and c["reduced_chi2"] > 10, c
    assert c["rms_m"] > 3 * c["expected_rms_m"]
    assert np.all(res.std >= res.std_raw) and np.all(res.std <= c["std_inflation"] * res.std_raw * 1.0001)
    assert res.std[0] > 2 * res.std_raw[0]  # log softness: determined by the data, inflated
    # the command: the line in the summary and the keys in the JSON report
    real, out, report = tmp_path / "tilted.csv", tmp_path / "cal.toml", tmp_path / "cal.json"
    write_dataset(real, u, _noisy(tips["tilted"], 0), {"robot": {"name": "three-cable"}})
    argv = ["calibrate", str(real), "--out", str(out), "--report", str(report), "--noise-m", str(NOISE_M)]
    assert main([*argv, "--n-rings", "1", "--n-axial", "6"]) == 0
    err = capsys.readouterr().err
    assert "the calibrated model does not explain these samples: residual" in err
    assert f"{1e3 * c['rms_m']:.3f} mm RMS against {1e3 * c['expected_rms_m']:.3f} mm expected from the noise" in err
    summary = json.loads(report.read_text())
    assert summary["model_discrepancy"] is True and summary["std_reported"] == "inflated"
    d = summary["discrepancy"]
    assert d["chi2"] == pytest.approx(c["chi2"]) and d["p_value"] < 1 - DISCREPANCY_QUANTILE
    assert set(d) >= {"rms_m", "expected_rms_m", "noise_m", "dof", "p", "p_eff", "reduced_chi2", "std_inflation"}
    names = list(summary["parameters"])
    assert list(summary["std_raw"]) == names == list(summary["std_inflated"])
    for n in names:  # the parameters' std is the reported (inflated) one
        assert summary["parameters"][n]["std"] == summary["std_inflated"][n] >= summary["std_raw"][n]


def test_in_class_report_says_the_model_explains_the_samples(three_cable, arms, tmp_path, capsys):
    u, tips, _ = arms
    real, out = tmp_path / "real.csv", tmp_path / "cal.toml"
    write_dataset(real, u, _noisy(tips["in-class"], 0), {"robot": {"name": "three-cable"}})
    argv = ["calibrate", str(real), "--out", str(out), "--noise-m", str(NOISE_M), "--n-rings", "1", "--n-axial", "6"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["model_discrepancy"] is False and "the calibrated model explains these samples" in captured.err
    assert summary["std_reported"] == ("inflated" if summary["discrepancy"]["reduced_chi2"] > 1 else "raw")
