"""Families of emulated as-built robots: one :class:`Family`, drawn three ways (``twin:random|foam|pneumatic``).

The shipped defects file is *one* as-built arm; a finding that holds on it may hold only on
it. A :class:`Family` draws member ``seed`` of a family of as-built arms instead, for any
robot description: the same seed gives the same robot and the same file, and results on a
member are an **emulated as-built robot** (:attr:`Family.label`), never the real arm. A
family is a parameter object -- its draw, ranges, header and recorded name -- and one
code path turns it into :class:`~lab.asbuilt.fields.Defects` (:meth:`Family.defects`), a
commented defects file (:meth:`Family.toml`, :func:`lab.asbuilt.writer.defects_toml`;
``python -m lab defects --random SEED``) or that file on disk (:meth:`Family.write`).
:data:`RANDOM` draws uniformly from :data:`~lab.asbuilt.draw.RANGES`
(:func:`lab.asbuilt.draw.draw_member`); :data:`FOAM` adds, from streams of its own,
defects outside the calibrator's model class (:func:`lab.asbuilt.foam.draw_foam`);
:data:`PNEUMATIC` draws cast-silicone arms driven by pressure chambers
(:func:`lab.asbuilt.pneumatic.draw_pneumatic`), and the first two refuse such a robot.
:func:`family_member` reads a study's label (``"shipped"``, ``"random:SEED"``,
``"foam:SEED"``). Every range and why it is that wide: ``docs/design/rig.md``.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from lab.asbuilt.arm import Defects, as_built_robot, load_defects, parse_defects
from lab.asbuilt.draw import RANGES, draw_member
from lab.asbuilt.foam import FOAM_RANGES, draw_foam, foam_mesh
from lab.asbuilt.pneumatic import PNEUMATIC_RANGES, check_pneumatic_robot, draw_pneumatic
from lab.asbuilt.writer import defects_toml
from lab.description import RobotDescription
from lab.errors import FieldError

__all__ = ["Family", "RANDOM", "FOAM", "PNEUMATIC", "FAMILIES", "family_member", "parse_robot_seed"]

#: How an error names the rig string a member is named by (``twin:FAMILY:SEED``); the
#: command line writes the flag the user typed in its place.
RIG = "RigSpec.rig"


@dataclass(frozen=True)
class Family:
    """A family of emulated as-built robots: how member ``seed`` is drawn and written.

    Parameters
    ----------
    name : str
        The family's name in ``--rig twin:NAME:SEED`` and ``python -m lab defects --NAME SEED``.
    label : str
        What results on a member are (recorded with every result).
    version : int
        Version of the generator: a change of ranges or draws bumps it (same seed, other robot).
    generator : str
        The generator's name as a member's rig metadata records it.
    draw : callable
        ``draw(robot, seed, n_rings, n_axial) -> (data, notes)``: the parsed TOML document of
        member ``seed`` on the emulator mesh ``n_rings``/``n_axial`` (None: the family's
        default) and the notes its comments need (:func:`lab.asbuilt.writer.defects_toml`).
    ranges : mapping
        (low, high) of every drawn field, SI units, as the file's comments quote them.
    header : tuple of str
        The file's top comment lines, formatted with ``robot`` (its name), ``seed`` (int)
        and ``command`` (the command line that made it).
    emulator_mesh : callable
        ``emulator_mesh(robot, n_rings, n_axial) -> (n_rings, n_axial)``: the mesh a member
        runs on (None entries: the description's).
    recorded_name : bool
        Whether the rig metadata names the family (False keeps the first family's as it was).
    check_robot : callable or None
        ``check_robot(robot, family_name)``: InputError for a robot the family cannot draw
        (None: any robot the draw takes).
    """

    name: str
    label: str
    version: int
    generator: str
    draw: Callable[[RobotDescription, int, int | None, int | None], tuple[dict, dict]]
    ranges: Mapping[str, tuple[float, float]]
    header: tuple[str, ...]
    emulator_mesh: Callable[[RobotDescription, int | None, int | None], tuple[int | None, int | None]]
    recorded_name: bool = True
    check_robot: Callable[[RobotDescription, str], None] | None = None

    def defects(
        self, robot: RobotDescription, seed: int, *, n_rings: int | None = None, n_axial: int | None = None
    ) -> Defects:
        """Member ``seed`` of the family: an as-built copy of ``robot``.

        Parameters
        ----------
        robot : RobotDescription
            The nominal robot the member is an as-built copy of.
        seed : int
            The member, an integer >= 0.
        n_rings, n_axial : int or None
            The emulator's FEM mesh, written to the file's ``[emulator]`` (None: the
            family's default); eyelet shifts are kept inside it.

        Returns
        -------
        Defects
            The member's validated defects, ``path`` ``"NAME:SEED"``.
        """
        if self.check_robot is not None:
            self.check_robot(robot, self.name)
        data, _ = self.draw(robot, seed, n_rings, n_axial)
        defects = parse_defects(data, robot, f"{self.name}:{int(seed)}")
        as_built_robot(robot, defects)  # eyelets inside the body (guaranteed by the draw)
        return defects

    def toml(
        self,
        robot: RobotDescription,
        seed: int,
        *,
        n_rings: int | None = None,
        n_axial: int | None = None,
        command: str | None = None,
    ) -> str:
        """The defects file of member ``seed``: what :meth:`defects` returns, as commented TOML.

        Parameters
        ----------
        robot, seed, n_rings, n_axial
            As for :meth:`defects`.
        command : str or None
            The command line that made the file, recorded in its header (default: the
            equivalent ``python -m lab defects`` line).

        Returns
        -------
        str
            The file's text, in the format of the shipped defects files.
        """
        if self.check_robot is not None:
            self.check_robot(robot, self.name)
        data, notes = self.draw(robot, seed, n_rings, n_axial)
        mesh = "".join(f" --{k.replace('_', '-')} {v}" for k, v in (("n_rings", n_rings), ("n_axial", n_axial)) if v)
        seed = int(seed)
        command = command or f"python -m lab defects --{self.name} {seed} --robot {robot.name}{mesh} --out D.toml"
        header = [line.format(robot=robot.name, seed=seed, command=command) for line in self.header]
        return defects_toml(robot, data, notes, header=header, ranges=self.ranges)

    def write(
        self,
        path,
        robot: RobotDescription,
        seed: int,
        *,
        n_rings: int | None = None,
        n_axial: int | None = None,
        command: str | None = None,
    ) -> Defects:
        """Write member ``seed``'s defects file (:meth:`toml`) to ``path`` atomically.

        Parameters
        ----------
        path : str or Path
            The file to write.
        robot, seed, n_rings, n_axial, command
            As for :meth:`toml`.

        Returns
        -------
        Defects
            The member (what :func:`lab.asbuilt.arm.load_defects` reads back from ``path``).
        """
        from lab.files import atomic_write_text

        text = self.toml(robot, seed, n_rings=n_rings, n_axial=n_axial, command=command)
        defects = self.defects(robot, seed, n_rings=n_rings, n_axial=n_axial)
        atomic_write_text(path, text)
        return defects

    def describe(self, robot_seed: int) -> dict:
        """What a rig on member ``robot_seed`` records about it.

        Parameters
        ----------
        robot_seed : int
            The member.

        Returns
        -------
        dict
            ``label`` and ``family`` (its name where :attr:`recorded_name`, the robot seed,
            the generator and its version), JSON-ready.
        """
        name = {"name": self.name} if self.recorded_name else {}
        family = {**name, "robot_seed": robot_seed, "generator": self.generator, "version": self.version}
        return {"label": self.label, "family": family}


def _cable_robot(robot: RobotDescription, family: str) -> None:
    """Refuse a robot with chambers: the random and foam families draw cable defects."""
    if getattr(robot, "chambers", ()):
        raise FieldError(
            f"robot {robot.name!r} is driven by pressure chambers: the {family} family draws the defects of a "
            f"cable arm (eyelets, slack, play, servos); draw it from the pneumatic family ({RIG} twin:pneumatic:SEED)",
            RIG,
        )


# The headers and generator names below are what members' files and rig metadata have
# always recorded (paths of the modules that first wrote them): byte for byte the same files.
#: The first family: every in-class defect drawn uniformly from :data:`~lab.asbuilt.draw.RANGES`.
RANDOM = Family(
    name="random",
    label="emulated as-built robot",
    version=1,
    generator="lab.rig.family",
    draw=draw_member,
    ranges=RANGES,
    header=(
        "# As-built defects of {robot!r}: member {seed} of the family of emulated as-built robots",
        "# (lab/rig/family.py, generator version 1; --rig twin:random:{seed}), made by",
        "#     {command}",
        "# Every value is drawn uniformly from the range in its comment; lab/rig/family.py",
        "# says why each range is what it is (foam and fabrication tolerances). Results on",
        "# this robot are an emulated as-built robot, not the real arm. Frame W as in the",
        "# description (base at the origin, body along +x, gravity along -z); SI units.",
        "# Every field is validated by lab/rig/asbuilt.py, which also documents the model.",
    ),
    emulator_mesh=lambda robot, n_rings, n_axial: (n_rings, n_axial),
    recorded_name=False,
    check_robot=_cable_robot,
)
#: The second family: :data:`RANDOM`'s draws plus defects `calibrate` cannot fit (:mod:`lab.asbuilt.foam`).
FOAM = Family(
    name="foam",
    label="emulated as-built robot (foam family)",
    version=1,
    generator="lab.rig.foam_family",
    draw=draw_foam,
    ranges={**RANGES, **FOAM_RANGES},
    header=(
        "# As-built defects of {robot!r}: member {seed} of the foam family of emulated",
        "# as-built robots (lab/rig/foam_family.py, generator version 1;",
        "# --rig twin:foam:{seed}), made by",
        "#     {command}",
        "# The fields `calibrate` fits are those of --rig twin:random:{seed}; the foam law,",
        "# the cables' stiffness, creep, the mocap's frame error, [mount] and the finer",
        "# [emulator] mesh are outside its model class. Each drawn value comes from the range",
        "# in its comment (U uniform, logU log-uniform); lab/rig/foam_family.py says why.",
        "# Results on this robot are an emulated as-built robot (foam family), not the real arm.",
        "# Frame W as in the description (base at the origin, body along +x, gravity along",
        "# -z); SI units. Every field is validated by lab/rig/asbuilt.py, which also",
        "# documents the model.",
    ),
    emulator_mesh=foam_mesh,
    check_robot=_cable_robot,
)
#: The third family: cast-silicone arms driven by pressure chambers (:mod:`lab.asbuilt.pneumatic`).
PNEUMATIC = Family(
    name="pneumatic",
    label="emulated as-built robot (pneumatic family)",
    version=1,
    generator="lab.asbuilt.pneumatic",
    draw=draw_pneumatic,
    ranges=PNEUMATIC_RANGES,
    header=(
        "# As-built defects of {robot!r}: member {seed} of the pneumatic family of emulated",
        "# as-built robots (lab/asbuilt/pneumatic.py, generator version 1;",
        "# --rig twin:pneumatic:{seed}), made by",
        "#     {command}",
        "# A cast-silicone arm driven by pressure chambers: softness, curing gradient, each",
        "# cavity's core-pin errors and the silicone round it, a tilted base, each chamber's",
        "# pressure regulator (lag, dead time, gain, offset), the silicone's relaxation and",
        "# the motion capture. Each value comes from the range in its comment (U uniform);",
        "# lab/asbuilt/pneumatic.py says why. The rig's commands are the chambers' pressures",
        "# (Pa). Results on this robot are an emulated as-built robot (pneumatic family), not",
        "# a real arm. Frame W as in the description; SI units. Every field is validated by",
        "# lab/asbuilt/parse.py (meanings and limits: lab/asbuilt/fields.py).",
    ),
    emulator_mesh=lambda robot, n_rings, n_axial: (n_rings, n_axial),
    check_robot=lambda robot, family: check_pneumatic_robot(robot),
)
#: The families by name, as ``twin:NAME:SEED`` names them.
FAMILIES = {f.name: f for f in (RANDOM, FOAM, PNEUMATIC)}


def parse_robot_seed(text: str, spec: str | None = None, family: str = "random") -> int:
    """The robot seed of ``twin:FAMILY:SEED``.

    Parameters
    ----------
    text : str
        The seed as written.
    spec : str or None
        The whole string it came from, named in the error.
    family : str
        The family's name, for the error's example.

    Returns
    -------
    int
        The seed; InputError unless ``text`` is a non-negative integer.
    """
    where = f"rig {spec!r}: " if spec else ""
    if not re.fullmatch(r"[0-9]+", str(text)):
        raise FieldError(
            f"{where}the robot seed must be a non-negative integer ({RIG} twin:{family}:SEED, e.g. twin:{family}:3), "
            f"got {text!r}",
            RIG,
        )
    return int(text)


def family_member(robot: RobotDescription, label: str, **mesh) -> Defects:
    """The defects of a robot as the studies name it.

    Parameters
    ----------
    robot : RobotDescription
        The nominal robot.
    label : str
        ``"shipped"`` (its shipped defects file), ``"random:SEED"``, ``"foam:SEED"`` or ``"pneumatic:SEED"``
        (anything else is read as a seed of :data:`RANDOM`).
    **mesh
        ``n_rings``/``n_axial``: the emulator mesh the member is drawn for.

    Returns
    -------
    Defects
        The robot's as-built defects.
    """
    if label == "shipped":
        return load_defects(None, robot)
    for family in (FOAM, PNEUMATIC):
        if label.startswith(f"{family.name}:"):
            seed = parse_robot_seed(label.removeprefix(f"{family.name}:"), label, family.name)
            return family.defects(robot, seed, **mesh)
    return RANDOM.defects(robot, parse_robot_seed(label.removeprefix("random:"), label), **mesh)
