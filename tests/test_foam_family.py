"""The foam family of emulated as-built robots (lab.asbuilt.FOAM, ``--rig twin:foam:SEED``,
``python -m lab defects --foam SEED``): the random family unchanged, the same in-class draws,
the out-of-class fields within their ranges, the TOML round trip and a capture end to end.
Emulators run on coarse meshes."""

import dataclasses
import hashlib
import json
import math

import numpy as np
import pytest

from lab.asbuilt import FOAM, RANDOM, family_member
from lab.asbuilt.arm import SeriesCableFEM, load_defects
from lab.asbuilt.foam import FOAM_RANGES, foam_mesh
from lab.cli import main
from lab.description import ROBOTS_DIR, load_robot
from lab.errors import InputError
from lab.fem import MeshSpec
from lab.fem.materials.hyperfoam import hyperfoam_matching
from lab.rig import FamilyTwinRig, RigSpec, as_built_body, make_rig

COARSE = dict(n_rings=1, n_axial=6)

#: sha256 of RANDOM.toml(...) text, printed by the code before the foam family
#: existed (git 083f1b7): the random family must stay bit for bit what it was.
RANDOM_BEFORE = {
    ("three-cable", 3, ()): "ebca4146761960821f9dc4d06349e3d55502268f35a569d9d3bcbd4a8da51220",
    ("three-cable", 0, (("n_rings", 2), ("n_axial", 4))): (
        "4e4759beab64720ac8bb33eeaffe5c58f909009e6fc24f9aa33038cfe5a75d78"
    ),
    ("six-cable", 5, (("n_rings", 2),)): "272a5be8b86f2431b451f833931eadfa36e8cb532eb21ab59dfe108eb0f92344",
    ("three-cable", 123456789, (("n_rings", 1), ("n_axial", 6))): (
        "ffa80e7ae637500ff4332cd9fded7438aa6f6b3c97b1a367c4e432d360a9cdcd"
    ),
}


def test_the_random_family_is_unchanged(three_cable):
    for (name, seed, mesh), digest in RANDOM_BEFORE.items():
        text = RANDOM.toml(load_robot(name), seed, **dict(mesh))
        assert hashlib.sha256(text.encode()).hexdigest() == digest, (name, seed, mesh)
    assert RigSpec.parse("twin:random:2").as_dict()["rig"] == "twin:random:2"
    assert "family" not in RigSpec.parse("twin:random:2").as_dict()  # its metadata as before


def test_same_seed_same_file_and_the_seeds_differ(three_cable, tmp_path):
    a, b = tmp_path / "a.toml", tmp_path / "sub" / "b.toml"
    FOAM.write(a, three_cable, 3)
    FOAM.write(b, three_cable, 3)
    assert a.read_bytes() == b.read_bytes() == FOAM.toml(three_cable, 3).encode()
    assert not list(tmp_path.rglob(".*.tmp*"))
    assert len({FOAM.defects(three_cable, s).sha256 for s in range(8)}) == 8
    text = a.read_text()
    assert "member 3 of the foam family" in text and "--rig twin:foam:3" in text and "logU(200, 2000)" in text


IN_CLASS = ("softness", "gradient", "tau_fast_s", "tau_slow_s", "slow_fraction", "ticks_per_rev")
IN_CLASS += ("profile_velocity_rad_s", "frame_rate_hz", "noise_sigma_m", "dropout_rate_hz", "dropout_max_frames")


@pytest.mark.parametrize("name, mesh", [("three-cable", {}), ("three-cable", COARSE), ("six-cable", {})])
def test_the_in_class_draws_are_those_of_the_random_member(name, mesh):
    robot = load_robot(name)
    for seed in range(6):
        rand, foam = RANDOM.defects(robot, seed, **mesh), FOAM.defects(robot, seed, **mesh)
        for key in IN_CLASS:
            assert getattr(foam, key) == getattr(rand, key), (seed, key)
        assert np.array_equal(foam.gradient_direction_W, rand.gradient_direction_W)
        for f, r in zip(foam.cables, rand.cables):
            assert np.array_equal(f.via_shift_m, r.via_shift_m) and (f.slack_m, f.play_m) == (r.slack_m, r.play_m)
            assert r.stiffness_n_per_m is None and f.stiffness_n_per_m is not None
        assert rand.law == "neo-hookean" and foam.law == "hyperfoam"


def test_the_foam_fields_are_within_their_ranges_and_spread(three_cable):
    E, nu = three_cable.youngs_modulus_pa, three_cable.poisson_ratio
    drawn = {k: [] for k in FOAM_RANGES}
    for seed in range(40):
        d = FOAM.defects(three_cable, seed)
        mu, beta = hyperfoam_matching(E, nu, d.hyperfoam_alpha)  # the description's E and nu
        assert d.hyperfoam_mu_pa == pytest.approx(mu, rel=1e-6) and d.hyperfoam_beta == pytest.approx(beta, rel=1e-6)
        assert abs(d.tilt_axis_W[2]) < 1e-12 and np.linalg.norm(d.tilt_axis_W) == pytest.approx(1.0)  # horizontal
        assert (d.n_rings, d.n_axial) == (4, 26) and d.slow_fraction + d.creep_fraction < 1
        drawn["hyperfoam_alpha"].append(d.hyperfoam_alpha)
        drawn["tilt_deg"].append(d.tilt_deg)
        drawn["frame_rotation_deg"].append(d.frame_rotation_deg)
        drawn["frame_offset_m"] += list(d.frame_offset_m)
        drawn["cable_stiffness_n_per_m"] += [c.stiffness_n_per_m for c in d.cables]
        drawn["creep_fraction"].append(d.creep_fraction)
        drawn["creep_tau_s"].append(d.creep_tau_s)
    for key, (lo, hi) in FOAM_RANGES.items():
        v = np.array(drawn[key])
        tol = 1e-6 * max(1.0, abs(hi))
        assert v.min() >= lo - tol and v.max() <= hi + tol, f"{key}: {v.min()}..{v.max()} outside {lo}..{hi}"
        assert v.max() - v.min() > 0.7 * (hi - lo), key
    k = np.log(drawn["cable_stiffness_n_per_m"])  # log-uniform: as many below the geometric mean as above
    assert abs(np.mean(k < math.log(math.sqrt(200 * 2000))) - 0.5) < 0.15
    assert foam_mesh(load_robot("six-cable")) == (4, 26) and foam_mesh(three_cable, 2, None) == (2, 26)


def test_the_foam_member_is_the_emulated_robot(three_cable):
    spec = RigSpec.parse("twin:foam:3")
    assert spec == RigSpec("twin", family_seed=3, family="foam") and str(spec) == "twin:foam:3"
    assert spec.label == FOAM.label == "emulated as-built robot (foam family)"
    assert spec.as_dict()["family"] == "foam" and RigSpec.parse(str(spec)) == spec
    coarse = dataclasses.replace(three_cable, n_rings=1, n_axial=4)
    body = as_built_body(spec, coarse)  # its own mesh, finer than the description's: (2, 6)
    assert body.fem.mesh.n_nodes == MeshSpec(2, 6).mesh(coarse).n_nodes and isinstance(body.fem, SeriesCableFEM)
    assert type(body.fem.elastic).__name__ == "Hyperfoam"
    assert family_member(coarse, "foam:3").sha256 == body.defects.sha256
    with pytest.raises(InputError, match="twin:foam:SEED"):
        family_member(three_cable, "foam:x")


@pytest.mark.parametrize(
    "text, words",
    [
        ("twin:foam", "needs the robot's seed: RigSpec.rig twin:foam:SEED"),
        ("twin:foam:", "needs the robot's seed: RigSpec.rig twin:foam:SEED"),
        ("twin:foam:abc", "robot seed must be a non-negative integer (RigSpec.rig twin:foam:SEED"),
        ("twin:foam:-1", "got '-1'"),
    ],
)
def test_bad_foam_strings(text, words):
    with pytest.raises(InputError) as err:
        RigSpec.parse(text)
    assert words in str(err.value) and "RigSpec.rig" in str(err.value)


def test_bad_foam_fields():
    with pytest.raises(InputError, match="twin:foam:SEED needs the robot's seed"):
        RigSpec("twin", family="foam")
    with pytest.raises(InputError, match="unknown family 'wild'"):
        RigSpec("twin", family_seed=1, family="wild")


def test_the_written_file_is_the_same_robot(tmp_path, capsys, three_cable):
    out = tmp_path / "foam3.toml"
    argv = ["defects", "--foam", "3", "--robot", "three-cable", "--n-rings", "1", "--n-axial", "6", "--out", str(out)]
    assert main(argv) == 0
    assert "member 3 of the foam family" in capsys.readouterr().err
    assert "--foam 3 --robot three-cable --n-rings 1 --n-axial 6" in out.read_text()
    loaded = load_defects(out, three_cable)
    assert loaded.sha256 == FOAM.defects(three_cable, 3, **COARSE).sha256
    u = np.array([1.5, 0.0, 0.8])
    with make_rig("twin:foam:3", three_cable, mesh=MeshSpec(**COARSE)) as drawn:
        assert isinstance(drawn, FamilyTwinRig) and drawn.family is FOAM and drawn.describe()["label"] == FOAM.label
        p_drawn = drawn.body.quasi_static_tip(u)
    with make_rig(f"twin:{out}", three_cable) as from_file:  # the file's [emulator] mesh
        assert np.array_equal(from_file.body.quasi_static_tip(u), p_drawn)
    with make_rig("twin:random:3", three_cable, mesh=MeshSpec(**COARSE)) as rand:
        assert np.linalg.norm(rand.body.quasi_static_tip(u) - p_drawn) > 1e-3  # another robot


def test_capture_on_a_foam_member_end_to_end(tmp_path, monkeypatch):
    text = (ROBOTS_DIR / "three-cable.toml").read_text()
    text = text.replace("n_rings = 3", "n_rings = 1").replace("n_axial = 20", "n_axial = 4")
    (tmp_path / "coarse.toml").write_text(text)
    monkeypatch.chdir(tmp_path)
    args = ["capture", "--rig", "twin:foam:3", "--robot", "coarse.toml", "--design", "random", "--n", "2"]
    assert main([*args, "--seed", "1", "--out", "real.csv", "--no-progress"]) == 0
    meta = json.loads((tmp_path / "real.csv.json").read_text())
    rig = meta["rig"]
    assert rig["label"] == FOAM.label and rig["family"] == {
        "name": "foam",
        "robot_seed": 3,
        "generator": "lab.rig.foam_family",
        "version": 1,
    }
    assert rig["defects"]["values"]["emulator"] == {"n_rings": 2, "n_axial": 6}  # finer than coarse.toml's
    assert rig["defects"]["values"]["material"]["law"] == "hyperfoam"
