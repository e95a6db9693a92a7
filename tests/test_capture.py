"""The capture protocol: settle detection, reset, the append-only resumable journal, its settings, CLI."""

import json
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from lab.asbuilt.arm import default_defects_path, parse_defects
from lab.capture.journal import Journal, JournalError, lock_path
from lab.capture.protocol import Protocol, SettleDetector, measure
from lab.capture.session import capture
from lab.capture.spec import CaptureSpec, ProtocolSpec
from lab.data.dataset import read_dataset
from lab.data.design_spec import DesignSpec
from lab.data.designs import grid_commands
from lab.errors import InputError
from lab.rig.base import MocapError, MocapFrame, Rig
from lab.rig.sim import SimRig
from lab.rig.spec import RigSpec
from lab.rig.twin import AsBuiltBody, TwinRig

COMMANDS = np.array(
    [[0.0, 0.0, 0.0], [1.5, 0.0, 0.0], [0.0, 3.0, 0.0], [1.0, 1.0, 1.0], [0.5, 0.0, 2.5], [3.0, 1.0, 0.0]]
)


@pytest.fixture(scope="module")
def twin_defects(three_cable):
    """The shipped defects, eyelets in place (the 1-ring test mesh is too thin for the
    shifts), and a wider play (0.3 mm) to make the history plain."""
    d = tomllib.loads(default_defects_path(three_cable).read_text())
    for c in d["cables"]:
        c.update(via_shift_m=[0.0, 0.0, 0.0], play_m=3e-4)
    d["emulator"] = {"n_rings": 1, "n_axial": 6}
    return parse_defects(d, three_cable)


@pytest.fixture(scope="module")
def twin_body(three_cable, twin_defects):
    return AsBuiltBody(three_cable, twin_defects)


class StopAfter(SimRig):
    """A sim rig that is 'killed' (KeyboardInterrupt) at its ``n``-th command."""

    n_sent, n = 0, None

    def __init__(self, robot, fem, n):
        super().__init__(robot, fem)  # sends the rest command, not counted
        self.n = n

    def _send(self, u):
        if self.n is not None:
            self.n_sent += 1
            if self.n_sent == self.n:
                raise KeyboardInterrupt
        super()._send(u)


class ScriptedRig(Rig):
    """Motors arrive at once; the tip is ``tip(t)`` (NaN = occluded)."""

    kind = "scripted"

    def __init__(self, robot, tip):
        super().__init__(robot, 120.0)
        self.tip, self.t, self.u = tip, 0.0, np.zeros(robot.n_cables)

    def _send(self, u):
        self.u = u

    def present_u(self):
        return self.u

    def now(self):
        return self.t

    def next_frame(self):
        self.t += 1 / 120
        return MocapFrame(self.t, np.asarray(self.tip(self.t), float))


# ------------------------------------------------------------------ settle detection
def test_settle_detector_is_the_papers_test():
    det = SettleDetector(n_previous=20, tol_m=1e-4)
    p = np.array([0.1, 0.0, 0.0])
    assert [det.update(p) for _ in range(21)] == [False] * 20 + [True]
    # NaN readings do not count
    det = SettleDetector(20, 1e-4)
    assert not any(det.update(np.full(3, np.nan)) for _ in range(30))
    # an exponential creep of 2 s: settled once |x_k - mean(previous 20)| <= tol
    det, tau, dt = SettleDetector(20, 1e-4), 2.0, 0.1
    x = [0.01 * np.exp(-k * dt / tau) for k in range(400)]
    k_settled = next(k for k in range(400) if det.update(np.array([x[k], 0, 0])))
    dev = [abs(x[k] - np.mean(x[k - 20 : k])) for k in range(20, 400)]
    assert k_settled == 20 + next(i for i, d in enumerate(dev) if d <= 1e-4)
    assert det.deviation_m <= 1e-4


def test_unsettled_sample_is_flagged_and_occlusion_is_an_error(three_cable):
    creeping = ScriptedRig(three_cable, lambda t: [0.2, 0.0, 1e-3 * t])  # 1 mm/s forever
    s = measure(creeping, [0.5, 0, 0], Protocol(reset=False, settle_timeout_s=5.0))
    assert not s.settled and 5.0 < s.t_done_s - s.t_command_s < 5.2
    assert s.p_tip_W[2] == pytest.approx(1e-3 * s.t_done_s, abs=1e-4)
    blind = ScriptedRig(three_cable, lambda t: [np.nan] * 3 if t > 1.0 else [0.2, 0, 0])
    with pytest.raises(MocapError, match="not seen for 2.0"):
        measure(blind, [0.5, 0, 0], Protocol(reset=False))
    flicker = ScriptedRig(three_cable, lambda t: [np.nan] * 3 if int(t * 120) % 3 else [0.2, 0, 0])
    s = measure(flicker, [0.5, 0, 0], Protocol(reset=False))
    assert s.settled and s.n_invalid_frames > s.n_frames / 2 and np.allclose(s.p_tip_W, [0.2, 0, 0])


# ------------------------------------------------------------------ the two tricks
def test_protocol_measures_the_quasi_static_tip(three_cable, twin_defects, twin_body):
    rig = TwinRig(three_cable, seed=0, body=twin_body)
    errors = {}
    for name, prot in (
        ("protocol", Protocol()),
        ("no-wait", Protocol(wait=False)),
        ("no-reset", Protocol(reset=False)),
    ):
        e = []
        for u in COMMANDS[[2, 1, 4, 3, 5]]:
            s = measure(rig, u, prot)
            e.append(np.linalg.norm(s.p_tip_W - twin_body.quasi_static_tip(u)))
            if name == "protocol":
                assert s.settled and s.t_arrived_s >= s.t_command_s and s.t_done_s - s.t_command_s > 2.0
                assert np.allclose(s.u_present, u, atol=2e-3)
        errors[name] = np.mean(e)
    assert errors["protocol"] < 0.5e-3  # residual creep + noise, sub-millimetre
    assert errors["no-wait"] > 10 * errors["protocol"]  # the foam is still creeping
    assert errors["no-reset"] > 2 * errors["protocol"]  # history (play) shows


def test_repeat_check_says_when_samples_drift(three_cable, twin_defects, tmp_path):
    """The first command measured again after the last: an unchanged robot gives its tip
    back within the threshold; one that creeps over minutes does not, and the capture says so."""
    import copy

    from lab.capture.repeat_check import repeat_check_line, repeat_threshold_m

    creeping = copy.deepcopy(twin_defects.source)
    creeping["lag"].update(creep_fraction=0.1, creep_tau_s=60.0)
    runs = {}
    for name, d in (("steady", twin_defects), ("creep", parse_defects(creeping, three_cable))):
        res = capture(TwinRig(three_cable, d, seed=2), COMMANDS, tmp_path / f"{name}.csv", repeat_check=True)
        runs[name] = res
        assert len(res.u_motor) == len(COMMANDS)  # the repeat is a note, not a sample
    steady, creep = runs["steady"].repeat_check, runs["creep"].repeat_check
    assert steady["threshold_m"] == repeat_threshold_m(Protocol()) == 4e-4
    assert not steady["drift"] and steady["distance_m"] < 0.2e-3
    assert creep["drift"] and creep["distance_m"] > 2 * creep["threshold_m"]
    assert repeat_check_line(runs["creep"]).startswith("samples drift")
    assert "repeat check" in repeat_check_line(runs["steady"])
    # resumed complete: nothing measured again, the note kept
    again = capture(TwinRig(three_cable, twin_defects, seed=2), COMMANDS, tmp_path / "steady.csv", repeat_check=True)
    assert [t for t, _ in again.notes].count("repeat-check") == 1 and again.repeat_check == steady


def test_a_resumed_repeat_check_measures_again(three_cable, twin_defects, tmp_path):
    """A capture on a creeping twin stopped during its repeat check and resumed: the new
    session starts where the first sample started (a twin from rest, same noise), so
    measuring the first command alone gave its journal row back bit for bit ("0.00 mm away")
    and never drift. The resumed check measures the last command first -- its row was made
    after minutes of creep -- and flags the drift the uninterrupted check flags; a steady
    twin's resumed check stays within the threshold."""
    import copy

    from lab.capture.repeat_check import repeat_check_line

    creeping = copy.deepcopy(twin_defects.source)
    creeping["lag"].update(creep_fraction=0.1, creep_tau_s=60.0)
    d = parse_defects(creeping, three_cable)
    sends_per_sample = 3  # reset up, release, command

    class StoppedInTheRepeat(TwinRig):
        n_sent = 0

        def _send(self, u):
            self.n_sent += 1
            if self.n_sent == sends_per_sample * len(COMMANDS) + 2:
                raise KeyboardInterrupt
            super()._send(u)

    def resumed(defects, journal):
        with pytest.raises(KeyboardInterrupt):
            capture(StoppedInTheRepeat(three_cable, defects, seed=2), COMMANDS, journal, repeat_check=True)
        return capture(TwinRig(three_cable, defects, seed=2), COMMANDS, journal, repeat_check=True)

    steady = resumed(twin_defects, tmp_path / "steady.csv").repeat_check
    assert not steady["drift"] and max(steady["distance_m"], steady["last"]["distance_m"]) < steady["threshold_m"]
    res = resumed(d, tmp_path / "creep.csv")
    rc = res.repeat_check
    assert res.new_samples == 0 and rc["resumed"] and rc["last"]["index"] == len(COMMANDS) - 1
    assert rc["p_again_m"] != rc["p_first_m"] and rc["distance_m"] > 0  # measured, not the first sample again
    assert rc["drift"] and rc["last"]["distance_m"] > 2 * rc["threshold_m"]
    line = repeat_check_line(res)
    assert line.startswith("samples drift: the first and the last command, measured again in a later session")


# ------------------------------------------------------------------ journal and resume
def test_resume_after_a_kill_gives_the_uninterrupted_dataset(three_cable, coarse_fem, tmp_path):
    full = capture(SimRig(three_cable, coarse_fem), COMMANDS, tmp_path / "full.csv", header={"x": 1})
    journal = tmp_path / "killed.csv"
    # sample 0 is (reset up, release, command) = sends 1-3; kill at send 8 = inside sample 2
    with pytest.raises(KeyboardInterrupt):
        capture(StopAfter(three_cable, coarse_fem, 8), COMMANDS, journal, header={"x": 1})
    assert len([ln for ln in journal.read_text().splitlines() if ln[:1].isdigit()]) == 2
    resumed = capture(SimRig(three_cable, coarse_fem), COMMANDS, journal, header={"x": 1})
    assert resumed.new_samples == len(COMMANDS) - 2
    assert np.array_equal(resumed.u_motor, full.u_motor)
    assert np.array_equal(resumed.p_tip_W[:2], full.p_tip_W[:2])  # from the journal, bit for bit
    # re-solved after the restart from another warm start: equal to the solver's tolerance
    assert np.abs(resumed.p_tip_W - full.p_tip_W).max() < 1e-6
    assert resumed.session.tolist() == [1, 1, 2, 2, 2, 2]
    tags = [t for t, _ in resumed.notes]
    assert tags == ["session", "session-end", "session", "session-end"]
    assert resumed.notes[1][1]["status"].startswith("stopped: KeyboardInterrupt")
    # a complete journal: nothing more to do, nothing duplicated
    again = capture(SimRig(three_cable, coarse_fem), COMMANDS, journal, header={"x": 1})
    assert again.new_samples == 0 and len(again.u_motor) == len(COMMANDS)


def test_resume_on_the_twin_keeps_old_samples_and_remeasures_the_rest(three_cable, twin_defects, tmp_path):
    def fresh(cls=TwinRig):
        return cls(three_cable, twin_defects, seed=1)

    full = capture(fresh(), COMMANDS, tmp_path / "full.csv")

    class Killed(TwinRig):
        n_sent = 0

        def _send(self, u):
            self.n_sent += 1
            if self.n_sent == 10:  # first command of sample 3
                raise RuntimeError("power cut")
            super()._send(u)

    with pytest.raises(RuntimeError, match="power cut"):
        capture(fresh(Killed), COMMANDS, tmp_path / "j.csv")
    resumed = capture(fresh(), COMMANDS, tmp_path / "j.csv")
    assert np.array_equal(resumed.u_motor, COMMANDS) and resumed.new_samples == 3
    assert np.array_equal(resumed.p_tip_W[:3], full.p_tip_W[:3])  # same seed, journaled: bit-identical
    assert np.abs(resumed.p_tip_W[3:] - full.p_tip_W[3:]).max() < 5e-4  # re-measured: repeatable


def test_torn_last_line_is_cut_and_recaptured(three_cable, coarse_fem, tmp_path):
    path = tmp_path / "j.csv"
    full = capture(SimRig(three_cable, coarse_fem), COMMANDS[:3], path)
    text = path.read_text()
    rows = [i for i, ln in enumerate(text.splitlines()) if ln[:1].isdigit()]
    lines = text.splitlines()
    torn = "\n".join(lines[: rows[-1]]) + "\n" + lines[rows[-1]][:25]  # killed while writing row 2
    path.write_text(torn)
    again = capture(SimRig(three_cable, coarse_fem), COMMANDS[:3], path)
    assert again.new_samples == 1 and np.array_equal(again.p_tip_W[:2], full.p_tip_W[:2])
    assert np.abs(again.p_tip_W - full.p_tip_W).max() < 1e-6


def test_journal_refuses_other_settings_corruption_and_a_second_writer(three_cable, coarse_fem, tmp_path):
    path = tmp_path / "j.csv"
    capture(SimRig(three_cable, coarse_fem), COMMANDS[:2], path)
    with pytest.raises(JournalError, match="protocol.wait: journal True, now False"):
        capture(SimRig(three_cable, coarse_fem), COMMANDS[:2], path, Protocol(wait=False))
    with pytest.raises(JournalError, match="commands.sha256"):
        capture(SimRig(three_cable, coarse_fem), COMMANDS[1:3], path)
    header = json.loads(path.read_text().split("\n")[0][len("# lab.journal 1 ") :])
    cols = path.read_text().split("\n")[1].split(",")
    with Journal.open(path, header, cols):
        with pytest.raises(JournalError, match="another process"):
            Journal.open(path, header, cols)
    lines = path.read_text().splitlines()
    row = next(i for i, ln in enumerate(lines) if ln[:1].isdigit())
    lines[row] = lines[row].replace(",", ";", 1)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(JournalError, match=f"line {row + 1} is corrupt"):
        Journal.open(path, header, cols)


def _header_and_columns(path):
    lines = path.read_text().split("\n")
    return json.loads(lines[0][len("# lab.journal 1 ") :]), lines[1].split(",")


def test_a_finished_capture_leaves_no_lock_file_and_a_held_journal_refuses_a_second(three_cable, coarse_fem, tmp_path):
    path, lock = tmp_path / "j.csv", lock_path(tmp_path / "j.csv")
    capture(SimRig(three_cable, coarse_fem), COMMANDS[:2], path)
    assert path.exists() and not lock.exists()  # removed when the capture ended
    with pytest.raises(JournalError, match="protocol.wait"):  # refused for other settings: no lock left either
        capture(SimRig(three_cable, coarse_fem), COMMANDS[:2], path, Protocol(wait=False))
    assert not lock.exists()
    with Journal.open(path, *_header_and_columns(path)):  # another writer holds the journal
        with pytest.raises(JournalError, match="being written by another process"):
            capture(SimRig(three_cable, coarse_fem), COMMANDS[:2], path)
        assert lock.exists()  # the refused capture left the holder's lock alone
    assert not lock.exists()
    again = capture(SimRig(three_cable, coarse_fem), COMMANDS[:2], path)
    assert again.new_samples == 0 and not lock.exists()


def test_capture_settings_name_the_flag_and_reproduce_the_command():
    for kwargs, words in [
        ({"settle_tol_mm": 0.0}, "ProtocolSpec.settle_tol_mm must be finite and > 0"),
        ({"reset_rad": -1.0}, "ProtocolSpec.reset_rad must be finite and >= 0"),
        ({"kind": "predictive", "predict_tol_mm": float("nan")}, "ProtocolSpec.predict_tol_mm must be a positive"),
        ({"dynamic_model": "d.npz"}, "ProtocolSpec.dynamic_model is for ProtocolSpec.kind predictive"),
        ({"kind": "predictive", "no_wait": True}, "cannot run with ProtocolSpec.no_wait or ProtocolSpec.no_reset"),
        ({"kind": "fast"}, "ProtocolSpec.kind must be one of wait, predictive"),
    ]:
        with pytest.raises(InputError, match=re.escape(words)):
            ProtocolSpec(**kwargs)
    p = ProtocolSpec(kind="predictive", predict_tol_mm=0.2, settle_tol_mm=0.05, reset_rad=0.5)
    protocol = p.protocol()
    assert protocol.kind == "predictive" and protocol.wait and protocol.reset and protocol.reset_u_rad == 0.5
    assert (protocol.predict_tol_m, protocol.settle_tol_m) == pytest.approx((2e-4, 5e-5))
    assert ProtocolSpec().protocol() == Protocol()  # the defaults are the shipped data's protocol
    design = DesignSpec(sobol=5, seed=2)
    spec = CaptureSpec(rig=RigSpec.parse("twin:random:3"), design=design, out="o.csv", order="grid", protocol=p)
    assert spec.journal_path == Path("o.journal.csv") and spec.seed == 2 and spec.progress
    assert spec.command == (
        "python -m lab capture --rig twin:random:3 --robot three-cable --design sobol --n 5 --out o.csv --seed 2 "
        "--order grid --protocol predictive --predict-tol-mm 0.2 --settle-tol-mm 0.05 --reset-rad 0.5"
    )
    assert CaptureSpec(out="o.csv", journal="j.csv").command.endswith("--order shuffled --journal j.csv")
    with pytest.raises(InputError, match="CaptureSpec.out is required"):
        CaptureSpec()
    with pytest.raises(InputError, match="CaptureSpec.order must be one of shuffled, grid"):
        CaptureSpec(out="o.csv", order="random")


def test_unsafe_command_is_refused_before_anything_moves(three_cable, coarse_fem, tmp_path):
    rig = SimRig(three_cable, coarse_fem)
    with pytest.raises(ValueError, match="safety rule"):
        capture(rig, np.array([[0, 0, 0], [3.0, 3.0, 3.0]]), tmp_path / "j.csv")
    assert not (tmp_path / "j.csv").exists()


# ------------------------------------------------------------------ command line
def _cli(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "lab", "capture", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env={"PYTHONPATH": str(cwd), "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"},
    )


def test_cli_end_to_end(three_cable, tmp_path):
    root = default_defects_path(three_cable).parents[2]
    defects = tmp_path / "coarse.toml"
    defects.write_text(
        default_defects_path(three_cable)
        .read_text()
        .replace("# [emulator]", "[emulator]")
        .replace("# n_rings = 1", "n_rings = 2")
        .replace("# n_axial = 6", "n_axial = 4")
    )
    out = tmp_path / "real.csv"
    args = ["--rig", f"twin:{defects}", "--grid", "2", "--out", str(out), "--seed", "3", "--no-progress"]
    r = _cli(*args, cwd=root)
    assert r.returncode == 0, r.stderr
    u, y, meta = read_dataset(out)
    assert np.array_equal(u, grid_commands(three_cable, 2))  # grid order, 7 safe of 8
    assert meta["capture"]["n_unsettled"] == 0 and 150 < meta["capture"]["rate_samples_per_hour"] < 600
    assert meta["rig"]["kind"] == "twin" and meta["protocol"]["wait"] and meta["sampler"]["order"] == "shuffled"
    assert meta["command"].startswith("python -m lab capture --rig twin:")
    assert meta["capture"]["repeat_check"]["drift"] is False and "repeat check: the first command" in r.stderr
    journal = tmp_path / "real.journal.csv"
    assert journal.exists() and not lock_path(journal).exists()
    with Journal.open(journal, *_header_and_columns(journal)):  # a second, concurrent writer is refused
        r = _cli(*args, cwd=root)
        assert r.returncode == 2 and "being written by another process" in r.stderr
        assert lock_path(journal).exists()
    r = _cli(*args, cwd=root)  # complete: rewrites, adds nothing
    assert r.returncode == 0 and "(0 new)" in r.stderr and not lock_path(journal).exists()
    assert np.array_equal(read_dataset(out)[1], y)
    r = _cli(*args, "--no-reset", cwd=root)
    assert r.returncode == 2 and "protocol.reset" in r.stderr
    r = _cli("--rig", f"twin:{tmp_path / 'nope.toml'}", "--grid", "2", "--out", str(tmp_path / "b.csv"), cwd=root)
    assert r.returncode == 2 and "defects file not found" in r.stderr
