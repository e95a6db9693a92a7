"""The ``--rig`` option as a typed spec (lab.rig.spec) and the one rig factory (lab.rig.factory)."""

import pytest

from lab.asbuilt import RANDOM
from lab.errors import InputError
from lab.fem import MeshSpec
from lab.fem.model import ArmFEM
from lab.rig import FamilyTwinRig, RigSpec, SimRig, TwinRig, as_built_body, make_rig

TWIN_MESH = MeshSpec(n_rings=2, n_axial=4)


@pytest.mark.parametrize(
    "text, fields",
    [
        ("sim", {"kind": "sim"}),
        ("twin", {"kind": "twin"}),
        ("twin:my/defects.toml", {"kind": "twin", "defects_path": "my/defects.toml"}),
        ("twin:C:/robots/d.toml", {"kind": "twin", "defects_path": "C:/robots/d.toml"}),
        ("twin:random:3", {"kind": "twin", "family_seed": 3}),
        ("twin:random:0", {"kind": "twin", "family_seed": 0}),
        ("hardware:rig.toml", {"kind": "hardware", "config_path": "rig.toml"}),
    ],
)
def test_every_form_parses_and_round_trips(text, fields):
    spec = RigSpec.parse(text)
    assert spec == RigSpec(**fields)
    assert str(spec) == text and RigSpec.parse(str(spec)) == spec
    assert spec.mesh == MeshSpec() and RigSpec.parse(spec) is spec


def test_empty_arguments_read_as_before():
    # make_rig always took "sim:" and "twin:" as the bare kinds
    assert RigSpec.parse("sim:") == RigSpec("sim")
    assert RigSpec.parse("twin:") == RigSpec("twin") and str(RigSpec.parse("twin:")) == "twin"


def test_the_mesh_rides_along_but_not_in_the_string():
    spec = RigSpec.parse("twin:random:2", mesh=MeshSpec(2, 8))
    assert spec.mesh == MeshSpec(2, 8) and str(spec) == "twin:random:2"
    assert spec.as_dict() == {
        "kind": "twin",
        "defects_path": None,
        "family_seed": 2,
        "config_path": None,
        "mesh": {"n_rings": 2, "n_axial": 8},
        "rig": "twin:random:2",
    }
    assert RigSpec.parse(spec, mesh=MeshSpec(3)).mesh == MeshSpec(3)


def test_file_label_and_dynamics():
    assert RigSpec.parse("twin:d.toml").file == "d.toml" and RigSpec.parse("hardware:c.toml").file == "c.toml"
    assert RigSpec.parse("twin:random:1").file is None and RigSpec.parse("sim").file is None
    assert [RigSpec.parse(t).label for t in ("sim", "twin", "hardware:c")] == [
        "FEM",
        "emulated as-built robot",
        "hardware",
    ]
    with pytest.raises(InputError, match="RigSpec.rig sim is the quasi-static FEM: it has no dynamics"):
        RigSpec.parse("sim").require_dynamics()
    twin = RigSpec.parse("twin")
    assert twin.require_dynamics() is twin


@pytest.mark.parametrize(
    "text, words",
    [
        ("warp", "unknown rig 'warp' (RigSpec.rig): expected sim, twin[:DEFECTS.toml], twin:random:SEED"),
        ("", "unknown rig ''"),
        ("sim:x", "rig 'sim' takes no argument (RigSpec.rig sim), got 'sim:x'"),
        ("twin:random", "needs the robot's seed: RigSpec.rig twin:random:SEED"),
        ("twin:random:", "needs the robot's seed: RigSpec.rig twin:random:SEED"),
        ("twin:random:abc", "robot seed must be a non-negative integer (RigSpec.rig twin:random:SEED"),
        ("twin:random:-1", "got '-1'"),
        ("twin:random:1.5", "got '1.5'"),
        ("twin:random:3:4", "got '3:4'"),
        ("hardware", "needs a configuration file: RigSpec.rig hardware:RIG.toml"),
        ("hardware:", "needs a configuration file: RigSpec.rig hardware:RIG.toml"),
    ],
)
def test_bad_strings_raise_input_errors_naming_the_flag(text, words):
    with pytest.raises(InputError) as err:
        RigSpec.parse(text)
    assert words in str(err.value) and "RigSpec.rig" in str(err.value)


@pytest.mark.parametrize(
    "fields, words",
    [
        ({"kind": "real"}, "unknown rig kind 'real'"),
        ({"kind": "sim", "defects_path": "d.toml"}, "RigSpec.rig sim takes no defects file"),
        ({"kind": "hardware", "config_path": "c", "family_seed": 1}, "RigSpec.rig hardware takes no robot seed"),
        ({"kind": "twin", "config_path": "c"}, "RigSpec.rig twin takes no configuration file"),
        ({"kind": "twin", "defects_path": "d", "family_seed": 1}, "not both"),
        ({"kind": "twin", "family_seed": -1}, "non-negative integer"),
        ({"kind": "twin", "family_seed": True}, "non-negative integer"),
        ({"kind": "twin", "family_seed": "3"}, "non-negative integer"),
        ({"kind": "hardware"}, "needs a configuration file"),
        ({"kind": "hardware", "config_path": "c", "mesh": MeshSpec(2)}, "MeshSpec.n_rings/MeshSpec.n_axial"),
        ({"kind": "twin", "mesh": (2, 8)}, "MeshSpec"),
    ],
)
def test_bad_fields_raise_input_errors_naming_the_flag(fields, words):
    with pytest.raises(InputError) as err:
        RigSpec(**fields)
    assert words in str(err.value) and "RigSpec.rig" in str(err.value)


def test_make_rig_on_a_given_fem_uses_that_fem(three_cable, coarse_fem):
    with make_rig("sim", three_cable, fem=coarse_fem) as rig:
        assert isinstance(rig, SimRig) and rig.fem is coarse_fem
    with make_rig(RigSpec("sim"), three_cable, fem=coarse_fem) as rig:
        assert rig.fem is coarse_fem


def test_make_rig_on_a_mesh_builds_that_mesh(three_cable):
    mesh = MeshSpec(n_rings=1, n_axial=4)
    want = mesh.mesh(three_cable).n_nodes
    assert want != ArmFEM(three_cable).mesh.n_nodes  # not the description's mesh
    with make_rig("sim", three_cable, mesh=mesh) as rig:
        assert rig.fem.mesh.n_nodes == want
    with make_rig(RigSpec.parse("sim", mesh=mesh), three_cable) as rig:
        assert rig.fem.mesh.n_nodes == want


def test_make_rig_twin_on_a_mesh(three_cable):
    want = TWIN_MESH.mesh(three_cable).n_nodes
    with make_rig("twin", three_cable, seed=4, mesh=TWIN_MESH) as rig:
        assert type(rig) is TwinRig and rig.seed == 4
        assert rig.body.fem.mesh.n_nodes == want and rig.describe()["mesh"]["n_nodes"] == want
        assert rig.defects.path is not None  # the shipped defects file


def test_make_rig_family_member_on_a_mesh(three_cable):
    want = TWIN_MESH.mesh(three_cable).n_nodes
    with make_rig("twin:random:3", three_cable, seed=1, mesh=TWIN_MESH) as rig:
        assert isinstance(rig, FamilyTwinRig) and rig.robot_seed == 3 and rig.seed == 1
        assert rig.body.fem.mesh.n_nodes == want
        assert rig.defects.sha256 == RANDOM.defects(three_cable, 3, **TWIN_MESH.overrides()).sha256
    body = as_built_body("twin:random:3", three_cable, mesh=TWIN_MESH)
    assert body.defects.sha256 == rig.defects.sha256 and body.fem.mesh.n_nodes == want


def test_make_rig_refuses_what_a_rig_cannot_take(three_cable, coarse_fem):
    with pytest.raises(InputError, match="only RigSpec.rig sim runs on a given nominal FEM"):
        make_rig("twin", three_cable, fem=coarse_fem)
    with pytest.raises(InputError, match="not both"):
        make_rig("sim", three_cable, fem=coarse_fem, mesh=MeshSpec(1, 4))
    with pytest.raises(InputError, match="MeshSpec.n_rings/MeshSpec.n_axial"):
        make_rig("hardware:rig.toml", three_cable, mesh=MeshSpec(2))
    with pytest.raises(InputError, match="RigSpec.rig twin only"):
        as_built_body("sim", three_cable)
    with pytest.raises(InputError, match="unknown rig 'warp'"):
        make_rig("warp", three_cable)
