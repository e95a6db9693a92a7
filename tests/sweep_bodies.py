"""Fault-sweep rows (tests/sweep.py format) for the description's bodies, tendons and markers.

Each row edits the case's copy of the three-cable robot (``robot.toml``) or writes the
tapered tentacle (``tentacle.toml``, examples/robots) and runs ``simulate`` on it: a bad
``[body]`` profile or mesh field, a tendon's control or tension bound, a marker's name or a
position in millimetres given as metres ends with exit 2 naming the field and the file,
before anything is written.
"""

import shutil

from sweep import COARSE, ROOT, Case

SIM = ["simulate", "--grid", "2", "--jobs", "1", "--no-progress", *COARSE]
ROBOT = [*SIM, "--robot", "{dir}/robot.toml", "--out", "{dir}/o.csv"]
TENTACLE = [*SIM, "--robot", "{dir}/tentacle.toml", "--out", "{dir}/o.csv"]


def edit(name, old, new):
    """A setup that replaces ``old`` by ``new`` in the case's copy of ``name``."""

    def setup(d):
        if name == "tentacle.toml":
            shutil.copy(ROOT / "examples" / "robots" / "tentacle.toml", d / name)
        p = d / name
        text = p.read_text()
        assert old in text, f"{name} has no {old!r}"
        p.write_text(text.replace(old, new, 1))

    return setup


def case(name, argv, words, setup):
    """A row refused with exit 2 whose output never appears."""
    return Case(name, argv, 2, words, setup=setup, absent=("{dir}/o.csv",))


OFFSETS = "[0.0203, 0.0177, 0.0152, 0.0126, 0.0101, 0.0080]"
PROFILE = "profile_m = [[0.0, 0.030], [0.05, 0.027], [0.30, 0.010]]"
BODY_CASES = [
    case(
        "body-unknown-shape",
        ROBOT,
        ('field \'body.shape\' must be "cylinder", "tapered" or "mesh"', "robot.toml"),
        edit("robot.toml", 'shape = "cylinder"', 'shape = "cone"'),
    ),
    case(
        "body-profile-on-a-cylinder",
        ROBOT,
        ("field 'body.profile_m' is not used by shape = \"cylinder\"",),
        edit("robot.toml", "radius_m = 0.02", "radius_m = 0.02\nprofile_m = [[0, 0.02], [0.2, 0.01]]"),
    ),
    case(
        "body-profile-not-from-zero",
        TENTACLE,
        ("field 'body.profile_m' must start at x = 0 and increase in x", "tentacle.toml"),
        edit("tentacle.toml", PROFILE, "profile_m = [[0.01, 0.030], [0.30, 0.010]]"),
    ),
    case(
        "body-profile-decreasing-x",
        TENTACLE,
        ("field 'body.profile_m' must start at x = 0 and increase in x",),
        edit("tentacle.toml", PROFILE, "profile_m = [[0.0, 0.030], [0.30, 0.027], [0.20, 0.010]]"),
    ),
    case(
        "body-profile-negative-radius",
        TENTACLE,
        ("field 'body.profile_m' radii must be positive",),
        edit("tentacle.toml", PROFILE, "profile_m = [[0.0, 0.030], [0.30, -0.010]]"),
    ),
    case(
        "body-profile-nan",
        TENTACLE,
        ("field 'body.profile_m' must be finite",),
        edit("tentacle.toml", PROFILE, "profile_m = [[0.0, 0.030], [0.30, nan]]"),
    ),
    case(
        "body-tapered-length-given",
        TENTACLE,
        ("field 'body.length_m' is not used by shape = \"tapered\"",),
        edit("tentacle.toml", PROFILE, PROFILE + "\nlength_m = 0.3"),
    ),
    case(
        "body-mesh-fields-on-a-cylinder",
        ROBOT,
        ("field 'mesh.size_m' is not used by body.shape = \"cylinder\"",),
        edit("robot.toml", "n_axial = 20", "n_axial = 20\nsize_m = 0.004"),
    ),
    case(
        "tendon-via-point-outside-taper",
        TENTACLE,
        ("cables[0]: via points must lie inside the body radius", "the radius there is"),
        edit(
            "tentacle.toml",
            "[0.0203, 0.0177, 0.0152, 0.0126, 0.0101, 0.0080]",
            "[0.0203, 0.0177, 0.0152, 0.0126, 0.0101, 0.0150]",
        ),  # fmt: skip
    ),
    case(
        "tendon-offsets-one-short",
        TENTACLE,
        ("field 'cables[0].offset_m' must be one positive offset per station (6)",),
        edit("tentacle.toml", OFFSETS, "[0.0203, 0.0177]"),
    ),
    case(
        "tendon-unknown-control",
        TENTACLE,
        ('field \'cables[0].control\' must be "angle" or "tension"',),
        edit("tentacle.toml", 'control = "tension"', 'control = "torque"'),
    ),
    case(
        "tendon-tension-without-bound",
        TENTACLE,
        ("missing field 'cables[0].tension_max_n'",),
        edit("tentacle.toml", "tension_max_n = 1.5\n", ""),
    ),
    case(
        "tendon-tension-bound-nan",
        TENTACLE,
        ("field 'cables[0].tension_max_n' must be a finite float",),
        edit("tentacle.toml", "tension_max_n = 1.5", "tension_max_n = nan"),
    ),
    case(
        "tendon-tension-bound-implausible",
        TENTACLE,
        ("field 'cables[0].tension_max_n' = 10000000.0 N is implausible",),
        edit("tentacle.toml", "tension_max_n = 1.5", "tension_max_n = 1e7"),
    ),
    case(
        "tendon-tension-with-slack",
        TENTACLE,
        ("field 'cables[0].slack_m' is not used by control = \"tension\"",),
        edit("tentacle.toml", "tension_max_n = 1.5", "tension_max_n = 1.5\nslack_m = 0.001"),
    ),
    case(
        "tendon-angle-with-tension-bound",
        ROBOT,
        ("field 'cables[0].tension_max_n' is not used by control = \"angle\"",),
        edit("robot.toml", 'name = "top"', 'name = "top"\ntension_max_n = 1.5'),
    ),
    case(
        "tendon-angle-needs-actuation",
        TENTACLE,
        ("missing table [actuation]",),
        edit("tentacle.toml", 'control = "tension"\ntension_max_n = 1.5\n', ""),
    ),
    case(
        "marker-named-tip",
        TENTACLE,
        ("field 'markers[0].name' must start with a letter", "not be 'tip'"),
        edit("tentacle.toml", 'name = "upper"', 'name = "tip"'),
    ),
    case(
        "marker-name-twice",
        TENTACLE,
        ("field 'markers[1].name' 'upper' is used twice",),
        edit("tentacle.toml", 'name = "middle"', 'name = "upper"'),
    ),
    case(
        "marker-in-mm-as-m",
        TENTACLE,
        ("field 'markers[0].position_m' [100.0, 33.6, 0.0] m is farther than twice the body's length", "metres?"),
        edit("tentacle.toml", "position_m = [0.10, 0.0336, 0.0]", "position_m = [100.0, 33.6, 0.0]"),
    ),
    case(
        "marker-misspelt-field",
        TENTACLE,
        ("[markers[0]] has no field 'position'", "did you mean 'position_m'?"),
        edit("tentacle.toml", "position_m = [0.10, 0.0336, 0.0]", "position = [0.10, 0.0336, 0.0]"),
    ),
]


def finger(old=None, new=None, extra=None):
    """A setup copying the finger example (its geometry beside it) and editing its TOML."""

    def setup(d):
        for name in ("finger.toml", "finger.geo"):
            shutil.copy(ROOT / "examples" / "robots" / name, d / name)
        if extra is not None:
            extra(d)
        if old is not None:
            p = d / "finger.toml"
            text = p.read_text()
            assert old in text, old
            p.write_text(text.replace(old, new, 1))

    return setup


def _inverted_vtu(d):
    """A two-tet mesh file whose second tet is wound the other way (an inverted element)."""
    import meshio
    import numpy as np

    X = np.array([[0, 0, 0], [0.01, 0, 0], [0, 0.01, 0], [0, 0, 0.01], [0.01, 0.01, 0.01]], float)
    meshio.write(d / "body.vtu", meshio.Mesh(X, [("tetra", np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))]))


FINGER = [*SIM[:-4], "--robot", "{dir}/finger.toml", "--out", "{dir}/o.csv"]
MESH_CASES = [
    case(
        "mesh-file-missing",
        FINGER,
        ("body.mesh_file", "nowhere.geo", "finger.toml"),
        finger('mesh_file = "finger.geo"', 'mesh_file = "nowhere.geo"'),
    ),
    case(
        "mesh-in-mm-given-as-m",
        FINGER,
        ('mesh_unit = "mm"?',),
        finger('mesh_unit = "mm"', 'mesh_unit = "m"'),
    ),
    case(
        "mesh-inverted-tets",
        FINGER,
        ("inverted",),
        finger('mesh_file = "finger.geo"', 'mesh_file = "body.vtu"', _inverted_vtu),
    ),
    case(
        "mesh-unknown-clamp-group",
        FINGER,
        ("'wrist'", "base"),
        finger('clamp_group = "base"', 'clamp_group = "wrist"'),
    ),
    case(
        "mesh-resolution-flag-refused",
        [*SIM, "--robot", "{dir}/finger.toml", "--out", "{dir}/o.csv"],
        ("--n-rings is not used by robot 'finger'", "body.mesh_file"),
        finger(),
    ),
    case(
        "marker-beyond-a-stalk",
        TENTACLE,
        ("markers[0].position_m",),
        edit("tentacle.toml", "position_m = [0.10, 0.0336, 0.0]", "position_m = [0.10, 0.25, 0.0]"),
    ),
]
BODY_CASES += MESH_CASES
