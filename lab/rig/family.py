"""A family of emulated as-built robots: seeded, random defects files (``--rig twin:random:SEED``).

The shipped defects file is *one* as-built arm; a finding that holds on it may hold only on
it. :func:`random_defects` draws member ``seed`` of a family of as-built arms instead, for
any robot description, uniformly and independently from :data:`RANGES` (every range
contains the shipped value and is wider than its spread; :data:`FIXED` holds hardware
settings). A cable's draws do not depend on how many cables the robot has, and the same
seed gives the same robot and the same file. Results on such a robot are an **emulated
as-built robot** (:data:`LABEL`), never the real arm. :func:`random_defects_toml` writes a
member as a commented defects file (``python -m lab defects --random SEED``),
:func:`write_random_defects` atomically; :class:`FamilyTwinRig` is the twin rig on one.
The draw itself is :func:`lab.rig.family_draw.draw_member`, the writer
:func:`lab.rig.family_toml.defects_toml`: a second family, :mod:`lab.rig.foam_family`
(``twin:foam:SEED``), adds defects outside the calibrator's model class to the same draws.
Every range and why it is that wide: ``docs/design/rig.md``.
"""

from __future__ import annotations

from lab.description import RobotDescription
from lab.rig.asbuilt import Defects, as_built_robot, load_defects, parse_defects
from lab.rig.family_draw import FIXED, RANGES, check_seed, draw_member
from lab.rig.family_toml import defects_toml, write_member
from lab.rig.foam_family import FOAM_FAMILY_VERSION, FOAM_LABEL, foam_defects
from lab.rig.spec import parse_robot_seed
from lab.rig.twin import AsBuiltBody, TwinRig

__all__ = [
    "FAMILY_VERSION",
    "RANGES",
    "FIXED",
    "LABEL",
    "random_defects",
    "family_member",
    "random_defects_toml",
    "write_random_defects",
    "parse_robot_seed",
    "FamilyTwinRig",
    "FoamTwinRig",
]

#: Version of the generator: a change of ranges or draws bumps it (same seed, other robot).
FAMILY_VERSION = 1
#: What results on a member of the family are.
LABEL = "emulated as-built robot"


def random_defects(
    robot: RobotDescription, seed: int, *, n_rings: int | None = None, n_axial: int | None = None
) -> Defects:
    """Member ``seed`` (an integer >= 0) of the family of as-built ``robot``s (ranges:
    :data:`RANGES`). ``n_rings``/``n_axial``: the emulator's FEM mesh, written to the
    file's ``[emulator]`` (default: the description's); eyelet shifts are kept inside it."""
    data, _ = draw_member(robot, seed, n_rings, n_axial)
    defects = parse_defects(data, robot, f"random:{int(seed)}")
    as_built_robot(robot, defects)  # eyelets inside the body (guaranteed by the draw)
    return defects


def family_member(robot: RobotDescription, label: str, **mesh) -> Defects:
    """The defects of a robot as the studies name it: ``"shipped"`` (its shipped defects file),
    ``"random:SEED"`` (:func:`random_defects`) or ``"foam:SEED"``
    (:func:`lab.rig.foam_family.foam_defects`), drawn for the mesh ``n_rings``/``n_axial``."""
    if label == "shipped":
        return load_defects(None, robot)
    if label.startswith("foam:"):
        return foam_defects(robot, parse_robot_seed(label.removeprefix("foam:"), label, "foam"), **mesh)
    return random_defects(robot, parse_robot_seed(label.removeprefix("random:"), label), **mesh)


def random_defects_toml(
    robot: RobotDescription,
    seed: int,
    *,
    n_rings: int | None = None,
    n_axial: int | None = None,
    command: str | None = None,
) -> str:
    """The defects file (TOML text with comments) of member ``seed``: what
    :func:`random_defects` returns, in the format of the shipped file
    (:func:`lab.rig.family_toml.defects_toml`). ``command``: the command line that made
    it, recorded in the header (default: the equivalent one)."""
    data, notes = draw_member(robot, seed, n_rings, n_axial)
    mesh = "".join(f" --{k.replace('_', '-')} {v}" for k, v in data.get("emulator", {}).items())
    command = command or f"python -m lab defects --random {int(seed)} --robot {robot.name}{mesh} --out D.toml"
    header = [
        f"# As-built defects of {robot.name!r}: member {int(seed)} of the family of {LABEL}s",
        f"# (lab/rig/family.py, generator version {FAMILY_VERSION}; --rig twin:random:{int(seed)}), made by",
        f"#     {command}",
        "# Every value is drawn uniformly from the range in its comment; lab/rig/family.py",
        "# says why each range is what it is (foam and fabrication tolerances). Results on",
        f"# this robot are an {LABEL}, not the real arm. Frame W as in the",
        "# description (base at the origin, body along +x, gravity along -z); SI units.",
        "# Every field is validated by lab/rig/asbuilt.py, which also documents the model.",
    ]
    return defects_toml(robot, data, notes, header=header, ranges=RANGES)


def write_random_defects(
    path, robot: RobotDescription, seed: int, *, n_rings=None, n_axial=None, command=None
) -> Defects:
    """Write member ``seed``'s defects file to ``path`` atomically; returns its
    :class:`Defects` (what :func:`lab.rig.asbuilt.load_defects` reads back from ``path``)."""
    return write_member(
        path, robot, seed, random_defects_toml, random_defects, n_rings=n_rings, n_axial=n_axial, command=command
    )


class FamilyTwinRig(TwinRig):
    """The twin rig on member ``robot_seed`` of the family (``--rig twin:random:SEED``).

    ``seed`` is the motion-capture noise seed, as for :class:`TwinRig`. ``describe()``
    records the robot seed, the generator version and the label, so that a dataset says
    which robot it came from."""

    #: The member's defects: ``(robot, robot_seed, **mesh) -> Defects``; a subclass draws another family.
    draw = staticmethod(random_defects)

    def __init__(self, robot: RobotDescription, robot_seed: int, seed: int = 0, **mesh):
        self.robot_seed = check_seed(robot_seed)
        super().__init__(robot, seed=seed, body=AsBuiltBody(robot, self.draw(robot, self.robot_seed, **mesh)))

    def describe(self) -> dict:
        return {
            **super().describe(),
            "label": LABEL,
            "family": {"robot_seed": self.robot_seed, "generator": "lab.rig.family", "version": FAMILY_VERSION},
        }


class FoamTwinRig(FamilyTwinRig):
    """The twin rig on member ``robot_seed`` of the foam family (``--rig twin:foam:SEED``).

    ``seed`` is the motion-capture noise seed, as for :class:`TwinRig`; ``n_rings``/
    ``n_axial`` override the member's own (finer) mesh. ``describe()`` records the family,
    the robot seed, the generator version and :data:`FOAM_LABEL`."""

    draw = staticmethod(foam_defects)

    def describe(self) -> dict:
        family = {"name": "foam", "robot_seed": self.robot_seed, "generator": "lab.rig.foam_family"}
        return {**super().describe(), "label": FOAM_LABEL, "family": {**family, "version": FOAM_FAMILY_VERSION}}
