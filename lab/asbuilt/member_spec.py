"""Which emulated as-built robot of the family: :class:`FamilyMemberSpec`, the ``defects`` settings.

A member of the family (:data:`lab.asbuilt.RANDOM`) is named by its seed (``--random SEED``, the
same as ``--rig twin:random:SEED``), a member of the foam family (:data:`lab.asbuilt.FOAM`)
by ``--foam SEED`` (``--rig twin:foam:SEED``), a member of the pneumatic family
(:data:`lab.asbuilt.PNEUMATIC`) by ``--pneumatic SEED`` (``--rig twin:pneumatic:SEED``; one
of the three), and drawn for the emulator
mesh it will run on (:class:`lab.fem.MeshSpec`, ``--n-rings``/``--n-axial``, written to the
file's ``[emulator]`` table). :meth:`FamilyMemberSpec.write` writes its defects file.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lab.asbuilt.family import RIG
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.specs import Spec, non_negative_int, option

__all__ = ["FamilyMemberSpec"]


@dataclass(frozen=True)
class FamilyMemberSpec(Spec):
    """Member ``seed`` of the family of as-built robots, member ``foam`` of the foam family or
    member ``pneumatic`` of the pneumatic family (exactly one), on the emulator mesh ``mesh``.

    Attributes
    ----------
    seed : int or None
        The member of the random family (``--random``), an integer >= 0.
    mesh : MeshSpec
        The emulator mesh the member is drawn for (``--n-rings``/``--n-axial``).
    foam : int or None
        Or the member of the foam family (``--foam``), an integer >= 0.
    pneumatic : int or None
        Or the member of the pneumatic family (``--pneumatic``), an integer >= 0.
    """

    seed: int | None = option(
        None,
        type=int,
        check=non_negative_int,
        help="the robot of the family to draw (an integer >= 0; the same as --rig twin:random:SEED)",
    )
    mesh: MeshSpec = field(default_factory=MeshSpec)
    foam: int | None = option(
        None,
        type=int,
        check=non_negative_int,
        help="or the robot of the foam family, with defects `calibrate` cannot fit (the same as "
        "--rig twin:foam:SEED; default mesh finer than the description's)",
    )
    pneumatic: int | None = option(
        None,
        type=int,
        check=non_negative_int,
        help="or the robot of the pneumatic family: a cast-silicone arm driven by pressure chambers (the same "
        "as --rig twin:pneumatic:SEED; --robot must have chambers, e.g. pneumatic-arm)",
    )

    def __post_init__(self):
        super().__post_init__()
        given = [k for k in ("seed", "foam", "pneumatic") if getattr(self, k) is not None]
        name = self.name_of
        if len(given) > 1:
            count = ("two", "three")[len(given) - 2]
            raise self.field_error(
                f"{' and '.join(name(k) for k in given)} name members of {count} families: give one of them",
                *given,
            )
        if not given:
            raise self.field_error(
                f"give {name('seed')} SEED ({RIG} twin:random:SEED), {name('foam')} SEED ({RIG} twin:foam:SEED) "
                f"or {name('pneumatic')} SEED ({RIG} twin:pneumatic:SEED)",
                "seed",
                "foam",
                "pneumatic",
                RIG,
            )

    @property
    def family(self) -> str:
        """``"random"``, ``"foam"`` or ``"pneumatic"``: the family of the member."""
        if self.pneumatic is not None:
            return "pneumatic"
        return "random" if self.foam is None else "foam"

    @property
    def member_seed(self) -> int:
        """The member's seed in its family."""
        return {"random": self.seed, "foam": self.foam, "pneumatic": self.pneumatic}[self.family]

    def write(self, path, robot, command: str | None = None):
        """Write the member's commented defects file for ``robot`` to ``path`` (atomically).

        A mesh that would not fit in memory is refused here (InputError), not first by the
        command that runs the emulator.

        Parameters
        ----------
        path : str or Path
            The file to write.
        robot : RobotDescription
            The nominal robot the member is drawn for.
        command : str or None
            The command line recorded in the file's header (default: the equivalent one).

        Returns
        -------
        Defects
            The member (:meth:`lab.asbuilt.Family.write`).
        """
        from lab.asbuilt.family import FAMILIES

        family = FAMILIES[self.family]
        if family.check_robot is not None:  # a robot the family cannot draw, before the mesh
            family.check_robot(robot, family.name)
        if self.family != "pneumatic":  # a chambered body is meshed by gmsh (the draw refuses a mesh)
            MeshSpec(*family.emulator_mesh(robot, self.mesh.n_rings, self.mesh.n_axial)).resolve(robot)
        return family.write(path, robot, self.member_seed, **self.mesh.overrides(), command=command)
