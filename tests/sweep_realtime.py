"""Fault-sweep rows (tests/sweep.py format) for the real-time loops that measure their own
pace (lab.capture.pace) and for the capture's repeat check stopped and resumed.

A row runs one command as a user would; starving a run on purpose needs a rig that drops
frames, which only a test can make (tests/test_dynamics.py, tests/test_predictive.py), so
the rows here check that an unstarved run says and records the pace it kept, and that a
repeat check interrupted by Ctrl-C measures again when resumed.
"""

import json
from pathlib import Path

import numpy as np
from sweep import Case

TWIN_MESH = ["--n-rings", "2", "--n-axial", "8"]  # the coarsest mesh the twin's eyelets fit
INPUTS = ("{dir}/model.npz", "{dir}/defects.toml", "{dir}/robot.toml")
FIT = ["fit-dynamics", "--n-steps", "1", "--n-random", "1", "--step-hold-s", "2", *TWIN_MESH, "--out", "{dir}/dyn.npz"]
STREAM = ["track", "--model", "{dir}/model.npz", "--rig", "twin", "--trajectory", "circle", *TWIN_MESH]
STREAM += ["--period-s", "2", "--n-periods", "1", "--lead-in-s", "0.5", "--command-rate-hz", "10"]
CAPTURE = ["capture", "--rig", "twin", "--grid", "2", "--no-progress", "--out", "{dir}/c.csv"]


def _fit_kept_pace(d: Path) -> None:
    with np.load(d / "dyn.npz") as z:
        pace = json.loads(str(z["metadata"]))["pace"]
    assert pace["achieved_rate_hz"] == 120.0 and pace["n_late_gaps"] == 0 and not pace["behind"], pace


def _stream_kept_pace(d: Path) -> None:
    pace = json.loads((d / "s.json").read_text())["info"]["pace"]
    assert pace["expected_frames"] == 240 and pace["n_frames"] >= 239 and not pace["behind"], pace
    assert pace["n_commands_late"] == 0 and pace["n_late_gaps"] == 0, pace


def _stopped_in_the_repeat_check(d: Path) -> None:
    """Run the row's capture, stopped by Ctrl-C as it measures the first command again."""
    import lab.capture.session as session
    from lab.cli import main

    measure, seen = session.measure, []

    def stopped(rig, u, protocol):
        if seen and np.array_equal(u, seen[0]):
            raise KeyboardInterrupt
        seen.append(np.asarray(u, float).copy())
        return measure(rig, u, protocol)

    session.measure = stopped
    try:
        assert main([a.replace("{dir}", str(d)) for a in CAPTURE]) == 130
    finally:
        session.measure = measure


def _resumed_repeat(d: Path) -> None:
    rc = json.loads((d / "c.csv.json").read_text())["capture"]["repeat_check"]
    assert rc["resumed"] and rc["p_again_m"] != rc["p_first_m"] and rc["last"]["distance_m"] > 0, rc


REALTIME_CASES: list = [
    Case(
        "realtime-fit-dynamics-says-its-pace",
        FIT,
        0,
        ("motion capture read at 120.0 Hz of 120 Hz",),
        INPUTS,
        after=_fit_kept_pace,
    ),
    Case(
        "realtime-stream-records-its-pace", [*STREAM, "--out", "{dir}/s.json"], 0, (), INPUTS, after=_stream_kept_pace
    ),
    Case(
        "realtime-resumed-repeat-check-measures-again",
        CAPTURE,
        0,
        ("repeat check: the first and the last command measured again in a later session",),
        INPUTS,
        setup=_stopped_in_the_repeat_check,
        after=_resumed_repeat,
    ),
]
