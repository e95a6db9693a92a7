"""The emulated as-built robot: defects file, as-built statics, motors, play, lag, mocap.

Everything runs on the coarse mesh (n_rings=1, n_axial=6) with defect files built from
the shipped default, so each physical effect can be switched on alone.
"""

import copy
import math
import tomllib

import numpy as np
import pytest

from lab.asbuilt.arm import (
    DefectsError,
    as_built_fem,
    as_built_robot,
    default_defects_path,
    load_defects,
    parse_defects,
)
from lab.fem.solve.statics import solve_static
from lab.rig import make_rig
from lab.rig.base import RigError
from lab.rig.mocap_model import MocapModel
from lab.rig.twin import AsBuiltBody, TwinRig, quasi_static_tips

COARSE = dict(n_rings=1, n_axial=6)


@pytest.fixture(scope="module")
def shipped(three_cable):
    return tomllib.loads(default_defects_path(three_cable).read_text())


@pytest.fixture
def clean(shipped):
    """A defects document with no defect at all, instant motors, no noise; tests edit it."""
    d = copy.deepcopy(shipped)
    d["material"].update(softness=1.0, gradient=0.0)
    for c in d["cables"]:
        c.update(via_shift_m=[0.0, 0.0, 0.0], slack_m=0.0, play_m=0.0)
    d["lag"].update(tau_fast_s=0.01, tau_slow_s=0.02, slow_fraction=0.5)
    d["motors"].update(ticks_per_rev=0, profile_velocity_rad_s=1e4)
    d["mocap"].update(noise_sigma_m=0.0, dropout_rate_hz=0.0)
    d["emulator"] = dict(COARSE)
    return d


def body_of(doc, robot):
    return AsBuiltBody(robot, parse_defects(doc, robot))


def settled_tip(body, u, t):
    """Command ``u`` at ``t`` and return (tip after 50 s, the new time)."""
    body.command(np.asarray(u, float), t)
    return body.state(t + 50.0)[1], t + 50.0


# ------------------------------------------------------------------ defects file
def test_shipped_defects_load(three_cable):
    d = load_defects(None, three_cable)
    assert d.softness < 1 and d.gradient > 0 and [c.name for c in d.cables] == [c.name for c in three_cable.cables]
    assert d.ticks_per_rev == 4096 and d.frame_rate_hz == 120.0 and d.noise_sigma_m < 1e-3
    assert d.sha256 == load_defects(default_defects_path(three_cable), three_cable).sha256


@pytest.mark.parametrize(
    "edit, field",
    [
        (lambda d: d["material"].update(softness=-1), "material.softness"),
        (lambda d: d["material"].update(gradient=1.2), "material.gradient"),
        (lambda d: d["material"].update(gradient_direction=[1, 0, 0]), "material.gradient_direction"),
        (lambda d: d["cables"][1].update(name="left"), "cables[1].name"),
        (lambda d: d["cables"][2].update(slack_m="3 mm"), "cables[2].slack_m"),
        (lambda d: d["cables"][0].update(via_shift_m=[0, 0]), "cables[0].via_shift_m"),
        (lambda d: d["cables"][0].update(via_shift_m=[0, 0, 0.01]), "cables[0].via_shift_m"),
        (lambda d: d["lag"].update(tau_slow_s=0.1), "lag.tau_slow_s"),
        (lambda d: d["lag"].pop("slow_fraction"), "lag.slow_fraction"),
        (lambda d: d["motors"].update(ticks_per_rev=4096.5), "motors.ticks_per_rev"),
        (lambda d: d.pop("mocap"), "[mocap]"),
        (lambda d: d.update(robot="six-cable"), "robot"),
        (lambda d: d["cables"].pop(), "[[cables]]"),
    ],
)
def test_bad_defects_name_the_field(three_cable, shipped, edit, field):
    doc = copy.deepcopy(shipped)
    edit(doc)
    with pytest.raises(DefectsError, match=field.replace("[", r"\[").replace("]", r"\]").replace(".", r"\.")):
        d = parse_defects(doc, three_cable)
        as_built_robot(three_cable, d)


def test_defects_file_errors(three_cable, tmp_path):
    with pytest.raises(DefectsError, match="not found"):
        load_defects(tmp_path / "missing.toml", three_cable)
    bad = tmp_path / "bad.toml"
    bad.write_text("softness = \n")
    with pytest.raises(DefectsError, match="not valid TOML"):
        load_defects(bad, three_cable)
    old = tmp_path / "old.toml"
    old.write_text('robot = "three-cable"\n')
    with pytest.raises(DefectsError, match=f"{old}: field 'format_version'"):
        load_defects(old, three_cable)


# ------------------------------------------------------------------ as-built statics
def test_no_defects_is_the_nominal_fem(three_cable, clean, coarse_fem):
    fem = as_built_fem(three_cable, parse_defects(clean, three_cable))
    for u in ([0, 0, 0], [1.5, 0.5, 0], [0, 2.0, 2.5]):
        assert np.allclose(solve_static(fem, u).p_tip_W, solve_static(coarse_fem, u).p_tip_W, atol=1e-9)


def test_quasi_static_tips_are_each_commands_own_equilibrium_in_any_order(three_cable, clean):
    """The tips are solved along a walk through the commands, each warm-started from a near
    one: the same equilibria (to the solver's tolerance) as a fresh body's for each command
    alone, returned in the commands' order, whatever that order; the noise is drawn in it."""
    doc = copy.deepcopy(clean)
    doc["material"]["softness"] = 0.8
    u = np.random.default_rng(1).uniform(0.0, 2.0, (7, 3))
    u = u[three_cable.is_safe(u)]
    tips = quasi_static_tips(body_of(doc, three_cable), u)
    alone = np.array([body_of(doc, three_cable).quasi_static_tip(ui) for ui in u])
    assert np.abs(tips - alone).max() < 1e-8
    shuffled = np.random.default_rng(2).permutation(len(u))
    assert np.abs(quasi_static_tips(body_of(doc, three_cable), u[shuffled]) - tips[shuffled]).max() < 1e-8
    noisy = quasi_static_tips(body_of(doc, three_cable), u, 1e-3, seed=5)
    assert np.allclose(noisy - tips, np.random.default_rng(5).normal(0.0, 1e-3, tips.shape), atol=1e-8)


def test_softer_body_sags_more(three_cable, clean, coarse_fem):
    clean["material"]["softness"] = 0.5
    fem = as_built_fem(three_cable, parse_defects(clean, three_cable))
    for u in ([0, 0, 0], [1.5, 0, 0], [0, 1.5, 1.5]):
        assert solve_static(fem, u).p_tip_W[2] < solve_static(coarse_fem, u).p_tip_W[2] - 4e-3


@pytest.mark.parametrize("direction", [[0, 1, 0], [0, -1, 0]])
def test_stiffness_gradient_veers_toward_the_softer_side(three_cable, clean, coarse_fem, direction):
    """E grows along ``gradient_direction``: the neutral axis moves to the stiff side, so
    the top cable (on the y = 0 plane) bends the arm toward the soft side."""
    clean["material"].update(gradient=0.6, gradient_direction=direction)
    d = parse_defects(clean, three_cable)
    fem = as_built_fem(three_cable, d)
    E = fem.elastic.mu * 2 * (1 + three_cable.poisson_ratio)
    centroid_s = fem.mesh.X_W[fem.mesh.tets].mean(axis=1) @ d.gradient_direction_W
    assert np.corrcoef(E, centroid_s)[0, 1] > 0.99 and np.isclose(E.mean(), three_cable.youngs_modulus_pa, rtol=0.05)
    moved = solve_static(fem, [1.5, 0, 0]).p_tip_W - solve_static(coarse_fem, [1.5, 0, 0]).p_tip_W
    assert moved @ d.gradient_direction_W < -3e-3


def test_slack_shifts_the_command_by_slack_over_spool_radius(three_cable, clean, coarse_fem):
    clean["cables"][1]["slack_m"] = 0.002
    fem = as_built_fem(three_cable, parse_defects(clean, three_cable))
    r = three_cable.spool_radius_m
    assert np.allclose(
        solve_static(fem, [0, 1.5, 0]).p_tip_W, solve_static(coarse_fem, [0, 1.5 - 0.002 / r, 0]).p_tip_W, atol=1e-9
    )
    # within the dead zone the cable does nothing
    assert np.allclose(solve_static(fem, [0, 0.15, 0]).p_tip_W, solve_static(fem, [0, 0, 0]).p_tip_W, atol=1e-9)


def test_eyelets_further_out_bend_less(three_cable, clean, coarse_fem):
    outward = 0.0015 * np.array([0.0, math.cos(math.radians(210)), math.sin(math.radians(210))])
    clean["cables"][1]["via_shift_m"] = outward.tolist()
    d = parse_defects(clean, three_cable)
    built = as_built_robot(three_cable, d)
    assert np.allclose(built.cables[1].via_points_m, three_cable.cables[1].via_points_m + outward)
    assert np.array_equal(built.cables[0].via_points_m, three_cable.cables[0].via_points_m)
    fem = as_built_fem(three_cable, d)
    rest = solve_static(coarse_fem, [0, 0, 0]).p_tip_W
    bend = np.linalg.norm(solve_static(fem, [0, 1.5, 0]).p_tip_W - rest)
    assert bend < np.linalg.norm(solve_static(coarse_fem, [0, 1.5, 0]).p_tip_W - rest) - 2e-4


# ------------------------------------------------------------------ body in time
def test_step_response_follows_the_two_time_constants(three_cable, clean):
    clean["lag"].update(tau_fast_s=0.4, tau_slow_s=2.5, slow_fraction=0.3)
    body = body_of(clean, three_cable)
    p0 = body.state(0.0)[1]
    body.command(np.array([1.5, 0, 0]), 0.0)  # the motors take 0.15 ms
    p1 = body.quasi_static_tip([1.5, 0, 0])
    step = p1 - p0
    for t in (0.4, 1.0, 2.5, 6.0):
        frac = (body.state(t)[1] - p0) @ step / (step @ step)
        assert frac == pytest.approx(1 - 0.7 * math.exp(-t / 0.4) - 0.3 * math.exp(-t / 2.5), abs=1e-3)
    # one mode alone: 63 % at its time constant
    clean["lag"].update(tau_fast_s=0.7, tau_slow_s=0.7)
    body = body_of(clean, three_cable)
    body.command(np.array([1.5, 0, 0]), 0.0)
    frac = (body.state(0.7)[1] - p0) @ step / (step @ step)
    assert frac == pytest.approx(1 - math.exp(-1), abs=1e-3)


def test_lag_is_integrated_exactly_whatever_the_call_times(three_cable, clean):
    clean["motors"]["profile_velocity_rad_s"] = 1.0  # equilibrium ramps for 2 s
    clean["lag"].update(tau_fast_s=0.3, tau_slow_s=2.0)
    a, b = body_of(clean, three_cable), body_of(clean, three_cable)
    for body in (a, b):
        body.command(np.array([2.0, 0, 0]), 0.5)
    for t in np.arange(0.5, 4.0, 1 / 120):
        a.state(t)
    for t in (0.9, 2.9):
        b.state(t)
    assert np.allclose(a.state(4.0)[1], b.state(4.0)[1], atol=1e-12)
    with pytest.raises(ValueError, match="backwards"):
        a.state(1.0)


def test_profile_velocity_and_quantisation(three_cable, clean):
    clean["motors"].update(ticks_per_rev=4096, profile_velocity_rad_s=2.0)
    body = body_of(clean, three_cable)
    tick = 2 * math.pi / 4096
    goal = np.array([1.0 + 0.3 * tick, 0.5, 0])
    body.command(goal, 0.0)
    u_mid = body.state(0.25)[0]
    assert np.allclose(u_mid, [0.5, 0.5, 0], atol=tick)  # 2 rad/s for 0.25 s, both motors
    u_end = body.state(1.0)[0]
    assert np.allclose(u_end / tick, np.rint(u_end / tick), atol=1e-9)
    assert np.allclose(u_end, np.rint(goal / tick) * tick)
    # a goal within the same tick is the same command
    assert np.array_equal(body.quasi_static_tip(goal), body.quasi_static_tip(np.rint(goal / tick) * tick))


def test_play_makes_a_hysteresis_loop_that_the_reset_erases(three_cable, clean):
    for c in clean["cables"]:
        c["play_m"] = 0.0005
    body = body_of(clean, three_cable)
    t = 0.0
    up, t = settled_tip(body, [1.5, 0, 0], t)  # loading
    _, t = settled_tip(body, [3.0, 0, 0], t)
    down, t = settled_tip(body, [1.5, 0, 0], t)  # unloading
    assert down[2] > up[2] + 1e-3  # the cable stays ahead when let out
    assert np.allclose(body.contraction_m, [0.015 + 0.0005, 0, 0])
    released, t = settled_tip(body, [0, 0, 0], t)
    virgin = AsBuiltBody(three_cable, parse_defects(clean, three_cable)).state(0.0)[1]
    assert released[2] > virgin[2] + 5e-4  # "never quite returns": slightly bent
    # The reset (all cables in by > 2 play, all out) makes the result independent of history.
    results = []
    for history in ([3.0, 0, 0], [0, 0, 0], [0.2, 2.5, 0.9]):
        _, t = settled_tip(body, history, t)
        _, t = settled_tip(body, [1.0, 1.0, 1.0], t)
        _, t = settled_tip(body, [0, 0, 0], t)
        tip, t = settled_tip(body, [1.5, 0.5, 0], t)
        results.append(tip)
    assert np.allclose(results, results[0], atol=1e-12)
    assert np.allclose(results[0], body.quasi_static_tip([1.5, 0.5, 0]), atol=1e-12)
    # without the reset, the history shows
    _, t = settled_tip(body, [3.0, 1.5, 0], t)
    no_reset, t = settled_tip(body, [1.5, 0.5, 0], t)
    assert np.linalg.norm(no_reset - results[0]) > 1e-3


# ------------------------------------------------------------------ motion capture
def test_mocap_noise_and_dropout_statistics():
    m = MocapModel(120.0, noise_sigma_m=2e-4, dropout_rate_hz=2.0, dropout_max_frames=24, seed=3)
    p = np.array([0.2, 0.01, -0.02])
    obs = np.array([m.observe(p) for _ in range(60000)])
    lost = np.isnan(obs).any(axis=1)
    assert np.array_equal(lost, np.isnan(obs).all(axis=1))
    ok = obs[~lost] - p
    assert np.allclose(ok.std(axis=0), 2e-4, rtol=0.03) and np.all(np.abs(ok.mean(axis=0)) < 1e-5)
    p_start, mean_len = 2.0 / 120, 12.5
    expected = p_start * mean_len / (1 + p_start * mean_len)  # a burst, then >= 1 seen frame
    assert lost.mean() == pytest.approx(expected, rel=0.1)
    edges = np.flatnonzero(np.diff(np.r_[0, lost.astype(int), 0]))
    bursts = edges[1::2] - edges[::2]
    assert bursts.max() <= 24 and m.n_dropped == lost.sum()


def test_twin_rig_frames_are_deterministic_per_seed(three_cable, clean):
    clean["mocap"].update(noise_sigma_m=1.5e-4, dropout_rate_hz=1.0)
    d = parse_defects(clean, three_cable)

    def run(seed):
        rig = TwinRig(three_cable, d, seed=seed)
        rig.send([1.0, 0.5, 0.0])
        return rig.frames(600)

    a, b, c = run(1), run(1), run(2)
    assert [f.t_s for f in a] == pytest.approx(np.arange(1, 601) / 120)
    A, B, C = (np.array([f.p_tip_W for f in x]) for x in (a, b, c))
    assert np.array_equal(A, B, equal_nan=True) and not np.array_equal(A, C, equal_nan=True)
    assert any(not f.valid for f in a) and np.isnan(A).any(axis=1).sum() == sum(not f.valid for f in a)


def test_twin_rig_interface(three_cable, clean, tmp_path):
    path = tmp_path / "coarse.toml"
    path.write_text(
        default_defects_path(three_cable)
        .read_text()
        .replace("# [emulator]", "[emulator]")
        .replace("# n_rings = 1", "n_rings = 2")
        .replace("# n_axial = 6", "n_axial = 6")
    )
    with make_rig(f"twin:{path}", three_cable, seed=5) as rig:
        desc = rig.describe()
        assert desc["kind"] == "twin" and desc["seed"] == 5 and desc["defects"]["path"] == str(path)
        assert desc["defects"]["sha256"] == load_defects(path, three_cable).sha256
        with pytest.raises(ValueError, match="safety rule"):
            rig.send([3.0, 3.0, 3.0])
        rig.send([0.0, 2.0, 0.0])
        rig.wait(0.5)
        assert rig.now() == pytest.approx(0.5) and rig.present_u()[1] == pytest.approx(1.0, abs=1e-2)
    with pytest.raises(RigError, match="closed"):
        rig.send([0, 0, 0])
