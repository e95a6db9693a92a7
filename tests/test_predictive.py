"""The predictive capture protocol (lab.capture.predictive) and its Kalman filter (lab.capture.tip_filter)."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from lab.asbuilt.arm import load_defects
from lab.capture.protocol import Protocol
from lab.capture.session import capture
from lab.capture.tip_filter import TipFilter
from lab.data.designs import random_commands
from lab.dynamics.relaxation import Relaxation
from lab.errors import InputError
from lab.rig.twin import AsBuiltBody, TwinRig

COARSE = {"n_rings": 2, "n_axial": 8}
PREDICTIVE = Protocol(kind="predictive", n_learn=8)


@pytest.fixture(scope="module")
def body(three_cable):
    return AsBuiltBody(three_cable, None, **COARSE)


def test_filter_predicts_a_step_target_long_before_it_settles():
    """Noise-free readings of the first 0.6 s of a step (slow mode 3 s, far from settled):
    the filter's target equals the true equilibrium; a waiting protocol would still be ~14 % short."""
    relax = Relaxation([0.3, 3.0], [0.6, 0.4], 1e-4)
    f = TipFilter(relax, process_noise_m2_per_s=0.0)
    for pose in ("reset", "rest"):
        f.set(pose, np.zeros(3), 1e-6)
    f.set("modes", np.zeros(3), 1e-6)
    f.t_s = 0.0
    target = np.array([0.01, -0.02, 0.03])
    times = np.arange(0.1, 0.61, 0.1)
    tips = relax.response([0.0, 0.0], np.vstack([np.zeros(3), target]), times)
    for t, y in zip(times, tips):
        f.advance(t, "rest", "target", 1.0, 1.0)
        f.update(y, 12)
    assert np.linalg.norm(f.x[f.index["target"]] - target) < 1e-5
    assert np.linalg.norm(tips[-1] - target) > 0.1 * np.linalg.norm(target)


def test_nan_and_empty_readings_never_change_the_filter():
    f = TipFilter(Relaxation([0.4, 2.5], [0.7, 0.3], 1e-4))
    x, P = f.x.copy(), f.P.copy()
    assert np.isnan(f.update(np.full(3, np.nan), 12))
    assert np.isnan(f.update(np.array([0.1, np.nan, 0.0]), 12))
    assert np.isnan(f.update(np.ones(3), 0))
    assert np.array_equal(f.x, x) and np.array_equal(f.P, P)


def test_predictive_capture_is_faster_and_as_accurate_on_the_twin(three_cable, body, tmp_path):
    """30 random commands: after 8 learning samples the predictive protocol records >= 2.5x
    faster than waiting, within 0.3 mm of the noise-free settled tips (waiting: ~0.3 mm),
    and learns the lag constants of the defects file."""
    u = random_commands(three_cable, 30, seed=4)
    truth = np.array([body.quasi_static_tip(ui) for ui in u])
    wait = capture(TwinRig(three_cable, body=body, seed=1), u, tmp_path / "wait.csv", Protocol())
    pred = capture(TwinRig(three_cable, body=body, seed=1), u, tmp_path / "pred.csv", PREDICTIVE)
    assert pred.predicted.sum() == 22 and not pred.predicted[:8].any()
    sel = pred.predicted
    rate_pred = 3600 * sel.sum() / pred.sample_s[sel].sum()
    assert rate_pred > 2.5 * wait.rate_per_hour
    err = np.linalg.norm(pred.p_tip_W - truth, axis=1)
    assert err[sel].mean() < 3e-4 and err[sel].max() < 6e-4
    assert np.all(pred.pred_std_m[sel] <= PREDICTIVE.predict_tol_m) and np.all(np.isnan(pred.pred_std_m[~sel]))
    (learned,) = [info for tag, info in pred.notes if tag == "relaxation"]
    d = body.defects
    assert learned["tau_s"] == pytest.approx([d.tau_fast_s, d.tau_slow_s], rel=0.1)
    assert learned["weight"][1] == pytest.approx(d.slow_fraction, abs=0.03)


class _Unplug(Exception):
    pass


def test_resumed_predictive_capture_reuses_the_learned_relaxation(three_cable, body, tmp_path):
    """Killed after 11 samples (8 learned), the same capture continues: no second learning phase."""
    u = random_commands(three_cable, 14, seed=5)
    rig = TwinRig(three_cable, body=body, seed=2)
    sends = {"n": 0}
    send = rig._send

    def failing_send(cmd):
        sends["n"] += 1
        if sends["n"] > 33:  # 3 commands per sample
            raise _Unplug
        send(cmd)

    rig._send = failing_send
    with pytest.raises(_Unplug):
        capture(rig, u, tmp_path / "j.csv", PREDICTIVE)
    res = capture(TwinRig(three_cable, body=body, seed=3), u, tmp_path / "j.csv", PREDICTIVE)
    assert res.new_samples == 3 and res.predicted.tolist() == [False] * 8 + [True] * 6
    assert len([n for n in res.notes if n[0] == "relaxation"]) == 1


def test_a_given_relaxation_skips_learning(three_cable, body, tmp_path):
    d = body.defects
    relax = Relaxation([d.tau_fast_s, d.tau_slow_s], [1 - d.slow_fraction, d.slow_fraction], d.noise_sigma_m)
    u = random_commands(three_cable, 5, seed=6)
    res = capture(TwinRig(three_cable, body=body), u, tmp_path / "j.csv", PREDICTIVE, relaxation=relax)
    assert res.predicted.all()
    truth = np.array([body.quasi_static_tip(ui) for ui in u])
    assert np.linalg.norm(res.p_tip_W - truth, axis=1).mean() < 5e-4


def test_predictive_protocol_settings_are_checked():
    with pytest.raises(InputError, match="protocol must be one of"):
        Protocol(kind="guess")
    with pytest.raises(InputError, match="cannot run without wait or reset"):
        Protocol(kind="predictive", reset=False)
    with pytest.raises(InputError, match="predict_tol_m"):
        Protocol(kind="predictive", predict_tol_m=0.0)
    # a waiting protocol's header is what it was before the predictive protocol existed
    assert "kind" not in Protocol().as_dict() and Protocol(kind="predictive").as_dict()["kind"] == "predictive"


def _coarse_defects(three_cable, path):
    import lab

    text = (Path(lab.__file__).parent / "rig" / "defects" / "three-cable.toml").read_text()
    path.write_text(text + "\n[emulator]\nn_rings = 2\nn_axial = 8\n")
    return path


def test_capture_cli_predictive_writes_protocol_and_uncertainty(three_cable, tmp_path, capsys):
    from lab.cli import main

    defects = _coarse_defects(three_cable, tmp_path / "coarse.toml")
    out = tmp_path / "pred.csv"
    argv = ["capture", "--rig", f"twin:{defects}", "--sobol", "14", "--protocol", "predictive", "--out", str(out)]
    assert main([*argv, "--no-progress"]) == 0
    meta = json.loads(out.with_suffix(".csv.json").read_text())
    assert meta["protocol"]["kind"] == "predictive" and meta["capture"]["protocol"] == "predictive"
    assert meta["capture"]["n_predicted"] == 4 and set(meta["capture"]["relaxation"]) >= {"tau_s", "weight"}
    std = meta["per_sample"]["pred_std_m"]
    assert sum(s is not None for s in std) == 4 and all(s is None or 0 < s <= 1.5e-4 for s in std)
    assert "--protocol predictive" in meta["command"]
    assert (
        main(["capture", "--sobol", "4", "--dynamic-model", str(tmp_path / "d.npz"), "--out", str(tmp_path / "x.csv")])
        == 2
    )
    assert "--dynamic-model is for --protocol predictive" in capsys.readouterr().err


@pytest.mark.slow
def test_predictive_capture_through_the_hardware_path(three_cable, tmp_path):
    """The real dynamixel-sdk and NatNet client against the emulated bus and server, driving an
    as-built body with a quick foam: the predictive capture runs unchanged. On the bench's
    virtual clock, so the frames' times and the body's lag do not depend on the machine's load."""
    from lab.rig.emulators import EmulatedBench
    from lab.rig.hardware import HardwareRig

    fast = dataclasses.replace(load_defects(None, three_cable), tau_fast_s=0.05, tau_slow_s=0.25)
    body = AsBuiltBody(three_cable, fast, **COARSE)
    u = random_commands(three_cable, 5, seed=7)
    protocol = Protocol(kind="predictive", n_learn=3, reset_u_rad=0.5, settle_timeout_s=10.0)
    with EmulatedBench(three_cable, body, noise_m=5e-5, virtual_time=True) as bench:
        cfg = bench.write_config(tmp_path / "rig.toml")
        with HardwareRig.from_config(cfg, three_cable, **bench.rig_options()) as rig:
            res = capture(rig, u, tmp_path / "j.csv", protocol)
    assert res.predicted.tolist() == [False] * 3 + [True] * 2
    truth = np.array([body.quasi_static_tip(ui) for ui in u])
    assert np.linalg.norm(res.p_tip_W - truth, axis=1).max() < 2e-3


def test_a_starved_predictive_capture_marks_its_dataset_degraded(three_cable, tmp_path, capsys, monkeypatch):
    """A predictive capture whose machine reads one frame in three (40 Hz of 120 Hz) finishes,
    but its metadata and summary say which rows were read behind the motion capture; the same
    capture unstarved is not degraded and reads every frame."""
    from lab.cli import main
    from lab.rig.twin import TwinRig

    defects = _coarse_defects(three_cable, tmp_path / "coarse.toml")
    Relaxation([0.4, 2.5], [0.7, 0.3], 5e-5).save(tmp_path / "d.npz")
    argv = ["capture", "--rig", f"twin:{defects}", "--sobol", "3", "--protocol", "predictive"]
    argv += ["--dynamic-model", str(tmp_path / "d.npz"), "--no-progress"]
    read = TwinRig.next_frame
    with monkeypatch.context() as m:
        m.setattr(TwinRig, "next_frame", lambda self: (read(self), read(self), read(self))[-1])
        assert main([*argv, "--out", str(tmp_path / "starved.csv")]) == 0
    err = capsys.readouterr().err
    pace = json.loads((tmp_path / "starved.csv.json").read_text())["capture"]["pace"]
    assert pace["degraded"] and pace["rows_behind"] == [0, 1, 2]
    assert pace["min_sample_rate_hz"] == pytest.approx(40.0, rel=0.02)
    assert "DEGRADED: 3 of 3 samples read the motion capture at under 50%" in err and "fell behind" in err
    assert main([*argv, "--out", str(tmp_path / "fed.csv")]) == 0
    pace = json.loads((tmp_path / "fed.csv.json").read_text())["capture"]["pace"]
    assert not pace["degraded"] and pace["rows_behind"] == [] and "DEGRADED" not in capsys.readouterr().err
    assert pace["min_sample_rate_hz"] == pytest.approx(120.0, rel=0.02)
