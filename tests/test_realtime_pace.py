"""Real-time loops measure their own pace: the frame-pace arithmetic, and the NatNet server
emulator counting the frame times it skipped while its thread ran late. (Streaming,
fit-dynamics and the predictive capture starved on purpose: tests/test_dynamics.py and
tests/test_predictive.py.)"""

import time

import numpy as np
import pytest

from lab.capture.pace import PaceMeter, frame_pace, samples_pace


def test_frame_pace_counts_rate_gaps_and_late_frames():
    t = np.arange(240) / 120.0
    full = frame_pace(t, 120.0)
    assert full.n_frames == full.expected_frames == 240 and full.fraction == pytest.approx(1.0)
    assert full.n_late == 0 and not full.behind
    starved = frame_pace(t[::40], 120.0, span_s=2.0)
    assert starved.n_frames == 6 and starved.expected_frames == 240 and starved.behind
    assert starved.n_late == 5 and starved.max_gap_s == pytest.approx(1 / 3)
    assert starved.missed().startswith("read 6 of 240 frames (2.5 %, 3.0 Hz of 120 Hz)")
    # the rate is kept but a fifth of the frames come after a hiccup of 3 periods: behind
    hiccups = np.concatenate([t[:200], t[200:] + np.repeat(np.arange(1, 5), 10) * 3 / 120])
    assert not frame_pace(t[:200], 120.0).behind and frame_pace(np.sort(hiccups), 120.0).n_late == 4
    meter = PaceMeter(120.0)
    for ti in t[::3]:
        meter.add(ti)
    assert meter.pace() == frame_pace(t[::3], 120.0)
    assert meter.pace().achieved_rate_hz == pytest.approx(40.0, rel=0.01)


def test_samples_pace_names_the_rows_read_behind():
    pace = samples_pace([480, 100, 0], [4.0, 4.0, 0.0], 120.0, rows=[2, 0, 1])
    assert pace["rows_behind"] == [0] and pace["min_sample_rate_hz"] == pytest.approx(25.0)
    assert pace["achieved_rate_hz"] == pytest.approx(580 / 8)


def test_the_natnet_emulator_counts_the_frame_times_it_skipped():
    """A frame that takes 0.2 s to make (a starved thread) skips at least 0.2 s - 2 periods of
    frame times at 120 Hz (22); the count is a lower bound, so load only makes it larger."""
    from lab.rig.emulators import MocapScene, NatNetServerEmulator

    server = NatNetServerEmulator(lambda t: np.zeros(3), MocapScene(), frame_rate_hz=120.0)
    make = server.frame
    slow = {"n": 0}

    def frame(number, t_s):
        slow["n"] += 1
        if slow["n"] == 3:
            time.sleep(0.2)
        return make(number, t_s)

    server.frame = frame
    with server:
        deadline = time.monotonic() + 30.0
        while server.frames_sent < 10 and time.monotonic() < deadline:
            time.sleep(0.01)
    assert server.frames_sent >= 10
    assert server.frames_skipped >= 20 and server.max_frame_gap_s >= 0.2
