"""Defects outside the calibrator's model class: base tilt, mocap frame error, cable
stiffness, creep, and the hyperfoam law's fields (lab.asbuilt.fields / defects_parse).

Everything runs on the coarse mesh (n_rings=1, n_axial=6), eyelets in place (the 1-ring
mesh is too thin for the shipped shifts). Absent -- or zero -- the new fields leave the
twin exactly as it was: the golden numbers below were printed by the code before them
(bit for bit on the machine that wrote them; 1e-12 m here, for other BLAS builds).
"""

import copy
import dataclasses
import math
import tomllib

import numpy as np
import pytest
from helpers import fd_jacobian

from lab.asbuilt.arm import DefectsError, SeriesCableFEM, as_built_fem, default_defects_path, load_defects
from lab.asbuilt.fields import rotation
from lab.asbuilt.parse import parse_defects
from lab.capture.protocol import measure
from lab.errors import InputError
from lab.fem.model import ArmFEM
from lab.fem.solve.statics import solve_static
from lab.rig.twin import AsBuiltBody, TwinRig, quasi_static_tips

COARSE = dict(n_rings=1, n_axial=6)
U = np.array([[0, 0, 0], [1.5, 0.5, 0], [0, 2.0, 2.5], [1.0, 1.0, 0.2]])
#: Shipped defects (eyelets in place, coarse mesh) before the optional fields existed. (U[2]'s
#: tip was re-recorded when quasi_static_tips began to walk the commands, U[2] after U[3]: its
#: warm start moved it 1.2e-11 m, within the solver's tolerance.)
GOLDEN_TIPS = [
    [0.19930901621365868, -0.0001376197014688809, -0.008359486237174125],
    [0.18818823128217657, -0.0023898846454521463, 0.03287472001941182],
    [0.17755039209258908, 0.01759041202123726, -0.0418632930394267],
    [0.1924962685481396, -0.01019780236973293, 0.011536350760054982],
]
GOLDEN_SAMPLES = [  # measure() on TwinRig(seed=7) of U[1:], one after the other
    [0.1882600332634955, -0.00242386110578189, 0.03263026859363843],
    [0.17758856488182026, 0.01747102504036033, -0.04171193883121659],
    [0.1924033055311842, -0.010023632085709113, 0.011188170024049251],
]
GOLDEN_T_DONE_S = [11.6, 25.1, 36.1]


@pytest.fixture(scope="module")
def shipped(three_cable):
    d = tomllib.loads(default_defects_path(three_cable).read_text())
    for c in d["cables"]:
        c["via_shift_m"] = [0.0, 0.0, 0.0]
    d["emulator"] = dict(COARSE)
    return d


@pytest.fixture
def clean(shipped):
    """No defect at all, instant motors, no noise."""
    d = copy.deepcopy(shipped)
    d["material"].update(softness=1.0, gradient=0.0)
    for c in d["cables"]:
        c.update(slack_m=0.0, play_m=0.0)
    d["lag"].update(tau_fast_s=0.01, tau_slow_s=0.02, slow_fraction=0.5)
    d["motors"].update(ticks_per_rev=0, profile_velocity_rad_s=1e4)
    d["mocap"].update(noise_sigma_m=0.0, dropout_rate_hz=0.0)
    return d


def zeroed(doc):
    """``doc`` with every optional field present at its no-effect value."""
    doc = copy.deepcopy(doc)
    doc["mount"] = {"tilt_deg": 0.0, "tilt_axis": [0.0, 1.0, 0.0]}
    doc["mocap"].update(frame_rotation_deg=0.0, frame_rotation_axis=[0, 0, 1], frame_offset_m=[0.0, 0.0, 0.0])
    doc["lag"].update(creep_fraction=0.0, creep_tau_s=60.0)
    doc["material"]["law"] = "neo-hookean"
    return doc


def run_twin(robot, doc):
    d = parse_defects(doc, robot)
    tips = quasi_static_tips(AsBuiltBody(robot, d), U)
    rig = TwinRig(robot, d, seed=7)
    return tips, [measure(rig, u) for u in U[1:]]


# ------------------------------------------------------------------ today's twin, bit for bit
def test_absent_or_zero_optional_fields_reproduce_todays_twin(three_cable, shipped):
    tips, samples = run_twin(three_cable, shipped)
    assert np.allclose(tips, GOLDEN_TIPS, rtol=0, atol=1e-12)
    assert np.allclose([s.p_tip_W for s in samples], GOLDEN_SAMPLES, rtol=0, atol=1e-12)
    assert [s.t_done_s for s in samples] == GOLDEN_T_DONE_S
    tips0, samples0 = run_twin(three_cable, zeroed(shipped))
    assert np.array_equal(tips0, tips)
    for a, b in zip(samples, samples0):
        assert np.array_equal(a.p_tip_W, b.p_tip_W) and np.array_equal(a.u_present, b.u_present)
        assert (a.t_done_s, a.n_frames, a.deviation_m) == (b.t_done_s, b.n_frames, b.deviation_m)
    assert type(as_built_fem(three_cable, parse_defects(zeroed(shipped), three_cable))) is ArmFEM


# ------------------------------------------------------------------ mount tilt
def test_tilt_about_the_lateral_axis_is_gravity_rotated(three_cable, clean):
    clean["mount"] = {"tilt_deg": 5.0, "tilt_axis": [0.0, 1.0, 0.0]}
    tilted = AsBuiltBody(three_cable, parse_defects(clean, three_cable))
    R = rotation([0, 1, 0], 5.0)
    assert np.allclose(R @ [1, 0, 0], [math.cos(math.radians(5)), 0, -math.sin(math.radians(5))])
    g_body = R.T @ three_cable.gravity_m_s2
    nominal = ArmFEM(dataclasses.replace(three_cable, gravity_m_s2=g_body), **COARSE)
    level = ArmFEM(three_cable, **COARSE)
    assert np.allclose(tilted.fem.f_gravity_W.sum(axis=0) / tilted.fem.m_node_kg.sum(), g_body)
    for u in U[:3]:
        got = tilted.quasi_static_tip(u)
        assert np.allclose(got, R @ solve_static(nominal, u).p_tip_W, rtol=0, atol=1e-9)
        drop = solve_static(level, u).p_tip_W[2] - got[2]
        assert 0.013 < drop < 0.022, drop  # ~ L sin 5 deg = 17 mm: the arm points down


# ------------------------------------------------------------------ mocap frame error
def test_frame_error_transforms_the_reported_tips_exactly(three_cable, clean):
    d0 = parse_defects(clean, three_cable)
    frame = dict(frame_rotation_deg=2.0, frame_rotation_axis=[0.3, -1.0, 0.5], frame_offset_m=[0.01, -0.02, 3e-3])
    clean["mocap"].update(frame)
    d = parse_defects(clean, three_cable)
    R, off = rotation(d.frame_rotation_axis_W, 2.0), np.array([0.01, -0.02, 3e-3])
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-15) and np.isclose(np.linalg.det(R), 1.0)
    tips0, tips = quasi_static_tips(AsBuiltBody(three_cable, d0), U), quasi_static_tips(AsBuiltBody(three_cable, d), U)
    assert np.allclose(tips, tips0 @ R.T + off, rtol=0, atol=1e-15)
    assert np.linalg.norm(tips - tips0, axis=1).min() > 5e-3
    frames = []
    for defects in (d0, d):
        rig = TwinRig(three_cable, defects, seed=1)
        rig.send(U[1])
        frames.append(np.array([f.p_tip_W for f in rig.frames(30)]))
    assert np.allclose(frames[1], frames[0] @ R.T + off, rtol=0, atol=1e-15)


# ------------------------------------------------------------------ cable stiffness
@pytest.fixture(scope="module")
def series_state(three_cable, shipped):
    doc = copy.deepcopy(shipped)
    for c, k in zip(doc["cables"], (300.0, 2e4, None)):
        c.update(slack_m=0.0, play_m=0.0)
        if k is not None:
            c["stiffness_n_per_m"] = k
    fem = as_built_fem(three_cable, parse_defects(doc, three_cable))
    u = np.array([1.5, 0.8, 0.5])  # cable 0 taut beyond the smoothing width, 1 and 2 within it
    q = solve_static(fem, u).q + 1e-5 * np.random.default_rng(0).standard_normal(fem.n_free)
    return fem, q, u


def test_series_cable_derivatives_match_finite_differences(series_state, three_cable):
    fem, q, u = series_state
    assert isinstance(fem, SeriesCableFEM)
    k = three_cable.cable_stiffness_n_m
    assert np.allclose(fem.cable_k_n_per_m, [k * 300 / (k + 300), k * 2e4 / (k + 2e4), k])
    assert fem.cable_k_n_per_m[2] == k  # no stiffness: the description's spring exactly
    stretch = fem.cable_lengths(fem.to_nodes(q)) - fem.cable_targets(u)
    assert stretch[0] > three_cable.slack_smoothing_m and np.all((0 < stretch[1:]) & (stretch[1:] < 2e-4))
    g = fem.gradient(q, u)
    assert np.abs(g - fd_jacobian(lambda z: fem.energy(z, u), q, 1e-7)).max() < 1e-6 * np.abs(g).max()
    H = fem.hessian(q, u).toarray()
    H_fd = fd_jacobian(lambda z: fem.gradient(z, u), q, 1e-7)
    assert np.abs(H - H_fd).max() < 1e-5 * np.abs(H).max()
    assert np.allclose(H, H.T, atol=1e-9 * np.abs(H).max())
    E_f, g_f, _, H_f = fem.energy(q, u, with_hessian=True)  # the line search's one pass: the correction too
    assert E_f == fem.energy(q, u) and np.abs(g_f - g).max() <= 1e-13 * np.abs(g).max()
    assert np.array_equal(H_f.toarray(), H)
    M_fd = fd_jacobian(lambda v: fem.gradient(q, v), u, 1e-7)
    assert np.abs(fem.mixed_derivative(q, u) - M_fd).max() < 1e-5 * np.abs(M_fd).max()
    v = np.random.default_rng(1).standard_normal(fem.n_free)
    assert np.abs(fem.hessian_operator(q, u)(v) - H @ v).max() < 1e-9 * np.abs(H @ v).max()


def test_stiff_cables_are_inextensible_and_soft_ones_move_the_tip_less(three_cable, clean):
    rigid = AsBuiltBody(three_cable, parse_defects(clean, three_cable))
    docs = {}
    for k in (1e9, 300.0):
        doc = copy.deepcopy(clean)
        for c in doc["cables"]:
            c["stiffness_n_per_m"] = k
        docs[k] = AsBuiltBody(three_cable, parse_defects(doc, three_cable))
    rest, soft_rest = rigid.quasi_static_tip([0, 0, 0]), docs[300.0].quasi_static_tip([0, 0, 0])
    assert soft_rest[2] < rest[2] - 3e-4  # the top cable holds some of the sag, less when it stretches
    for u in U[1:]:
        p = rigid.quasi_static_tip(u)
        assert np.abs(docs[1e9].quasi_static_tip(u) - p).max() < 1e-7
        soft = docs[300.0].quasi_static_tip(u)
        assert np.linalg.norm(soft - soft_rest) < 0.9 * np.linalg.norm(p - rest)


# ------------------------------------------------------------------ creep
def test_creep_keeps_the_tip_moving_over_its_time_constant(three_cable, clean):
    clean["lag"].update(creep_fraction=0.2, creep_tau_s=120.0)
    body = AsBuiltBody(three_cable, parse_defects(clean, three_cable))
    p0 = body.state(0.0)[1]
    body.command(np.array([1.5, 0.0, 0.0]), 0.0)  # motors take 0.15 ms; fast modes die in ~0.1 s
    p1 = body.quasi_static_tip([1.5, 0.0, 0.0])
    step = p1 - p0
    for t in (5.0, 60.0, 120.0, 300.0, 900.0):
        left = (p1 - body.state(t)[1]) @ step / (step @ step)  # share of the step still to go
        assert left == pytest.approx(0.2 * math.exp(-t / 120.0), rel=1e-4, abs=1e-12)
    clean["lag"].pop("creep_fraction"), clean["lag"].pop("creep_tau_s")
    plain = AsBuiltBody(three_cable, parse_defects(clean, three_cable))
    plain.command(np.array([1.5, 0.0, 0.0]), 0.0)
    assert np.abs(plain.state(5.0)[1] - p1).max() < 1e-12  # without creep: settled


# ------------------------------------------------------------------ the hyperfoam law
def test_hyperfoam_law_reaches_the_fem_scaled_per_tet(three_cable, shipped):
    from lab.fem.materials.hyperfoam import Hyperfoam, hyperfoam_matching

    neo = as_built_fem(three_cable, parse_defects(shipped, three_cable))
    mu, beta = hyperfoam_matching(three_cable.youngs_modulus_pa, three_cable.poisson_ratio, 8.0)
    doc = copy.deepcopy(shipped)
    doc["material"].update(law="hyperfoam", hyperfoam_mu_pa=float(mu), hyperfoam_alpha=8.0, hyperfoam_beta=beta)
    foam = as_built_fem(three_cable, parse_defects(doc, three_cable))
    assert isinstance(foam.elastic, Hyperfoam) and foam.elastic.alpha == 8.0 and foam.elastic.beta == beta
    assert np.allclose(foam.elastic.mu, neo.elastic.mu, rtol=1e-12)  # softness and gradient, per tet
    rest = [solve_static(f, [0, 0, 0]).p_tip_W for f in (neo, foam)]
    pulled = [solve_static(f, [3.0, 0, 0]).p_tip_W for f in (neo, foam)]
    assert np.linalg.norm(rest[0] - rest[1]) < 2e-4 < 1e-3 < np.linalg.norm(pulled[0] - pulled[1])
    doc["material"]["hyperfoam_alpha"] = -4.0  # a negative alpha: the same small-strain stiffness
    neg = as_built_fem(three_cable, parse_defects(doc, three_cable))
    assert neg.elastic.alpha == -4.0 and np.linalg.norm(solve_static(neg, [0, 0, 0]).p_tip_W - rest[0]) < 2e-4


def test_a_law_that_refuses_its_parameters_names_the_file(three_cable, shipped, monkeypatch):
    import lab.asbuilt.arm as asbuilt

    def refuse(*args):
        raise InputError("hyperfoam beta must be finite and >= 0")

    monkeypatch.setattr(asbuilt, "HyperfoamMaterial", refuse)
    doc = copy.deepcopy(shipped)
    doc["material"].update(HF)
    with pytest.raises(DefectsError, match=r'x\.toml: \[material\] law = "hyperfoam": hyperfoam beta'):
        as_built_fem(three_cable, parse_defects(doc, three_cable, "x.toml"))


# ------------------------------------------------------------------ validation
def _set(table, **kw):
    def edit(d):
        (d if table is None else d.setdefault(table, {})).update(kw)

    return edit


def _cable(i, **kw):
    return lambda d: d["cables"][i].update(kw)


HF = dict(law="hyperfoam", hyperfoam_mu_pa=1.3e4, hyperfoam_alpha=8.0, hyperfoam_beta=0.1)


@pytest.mark.parametrize(
    "edit, words",
    [
        (_set("mount", tilt_deg=float("nan"), tilt_axis=[0, 1, 0]), ("mount.tilt_deg", "[-30, 30] deg", "nan")),
        (_set("mount", tilt_deg=45.0, tilt_axis=[0, 1, 0]), ("mount.tilt_deg", "[-30, 30] deg")),
        (_set("mount", tilt_deg=3.0, tilt_axis=[0, 0, 0]), ("mount.tilt_axis", "nonzero length")),
        (_set("mount", tilt_deg=3.0), ("missing field 'mount.tilt_axis'",)),
        (_set("mount", tilt=3.0), ("[mount] has no field 'tilt'", "tilt_deg")),
        (
            _set("mocap", frame_rotation_deg=20.0, frame_rotation_axis=[0, 0, 1]),
            ("mocap.frame_rotation_deg", "[-10, 10] deg"),
        ),
        (_set("mocap", frame_rotation_deg=1.0), ("missing field 'mocap.frame_rotation_axis'",)),
        (_set("mocap", frame_offset_m=[0.2, 0, 0]), ("mocap.frame_offset_m", "<= 0.1 m")),
        (_set("mocap", frame_offset_m=[0, 0]), ("mocap.frame_offset_m", "3 finite numbers")),
        (_cable(1, stiffness_n_per_m=-5.0), ("cables[1].stiffness_n_per_m", "[10, 1e+12] N/m")),
        (_cable(0, stiffness_n_per_m=True), ("cables[0].stiffness_n_per_m",)),
        (_set("lag", creep_fraction=1.0, creep_tau_s=60.0), ("lag.creep_fraction", "[0, 1)")),
        (_set("lag", creep_fraction=0.8, creep_tau_s=60.0), ("lag.creep_fraction", "must be < 1")),
        (_set("lag", creep_fraction=0.1, creep_tau_s=1.0), ("lag.creep_tau_s", "[2.5, 86400] s")),
        (_set("lag", creep_fraction=0.1), ("missing field 'lag.creep_tau_s'",)),
        (_set("material", law="mooney-rivlin"), ("material.law", "'neo-hookean', 'hyperfoam'", "mooney-rivlin")),
        (_set("material", law="hyperfoam"), ("missing field 'material.hyperfoam_mu_pa'",)),
        (_set("material", **{**HF, "hyperfoam_alpha": 0.0}), ("material.hyperfoam_alpha", "nonzero")),
        (_set("material", **{**HF, "hyperfoam_alpha": 60.0}), ("material.hyperfoam_alpha", "[-50, 50]")),
        (_set("material", **{**HF, "hyperfoam_beta": 50.0}), ("material.hyperfoam_beta", "[0, 50)")),
        (_set("material", **{**HF, "hyperfoam_beta": -0.1}), ("material.hyperfoam_beta",)),
        (_set("material", **{**HF, "hyperfoam_mu_pa": 0.0}), ("material.hyperfoam_mu_pa", "(0, inf) Pa")),
        (_set("material", hyperfoam_alpha=8.0), ("material.hyperfoam_alpha", 'only with law = "hyperfoam"')),
    ],
)
def test_bad_optional_fields_name_the_field_and_range(three_cable, shipped, tmp_path, edit, words):
    doc = copy.deepcopy(shipped)
    edit(doc)
    with pytest.raises(DefectsError) as err:
        parse_defects(doc, three_cable)
    for w in words:
        assert w in str(err.value), str(err.value)


def test_file_errors_name_the_file_and_good_fields_are_kept(three_cable, shipped, tmp_path):
    path = tmp_path / "bad.toml"
    text = default_defects_path(three_cable).read_text()
    path.write_text(text + "\n[mount]\ntilt_deg = nan\ntilt_axis = [0.0, 1.0, 0.0]\n")
    with pytest.raises(DefectsError, match=f"{path}: field 'mount.tilt_deg'"):
        load_defects(path, three_cable)
    doc = zeroed(shipped)
    doc["material"].update(HF)
    doc["mount"]["tilt_deg"] = -2.0
    doc["cables"][2]["stiffness_n_per_m"] = 800
    d = parse_defects(doc, three_cable)
    assert (d.law, d.hyperfoam_mu_pa, d.hyperfoam_alpha, d.hyperfoam_beta) == ("hyperfoam", 1.3e4, 8.0, 0.1)
    assert d.cables[2].stiffness_n_per_m == 800.0 and d.cables[0].stiffness_n_per_m is None
    assert np.allclose(d.R_tilt, rotation([0, 1, 0], -2.0)) and d.R_frame is None and not d.has_frame_offset
    assert (d.creep_fraction, d.creep_tau_s) == (0.0, 60.0)
