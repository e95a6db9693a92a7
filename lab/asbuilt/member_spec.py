"""Which emulated as-built robot of the family: :class:`FamilyMemberSpec`, the ``defects`` settings.

A member of the family (:data:`lab.asbuilt.RANDOM`) is named by its seed (``--random SEED``, the
same as ``--rig twin:random:SEED``), a member of the foam family (:data:`lab.asbuilt.FOAM`)
by ``--foam SEED`` (``--rig twin:foam:SEED``; one of the two), and drawn for the emulator
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
    """Member ``seed`` of the family of as-built robots, or member ``foam`` of the foam
    family (exactly one of the two), on the emulator mesh ``mesh``.

    Attributes
    ----------
    seed : int or None
        The member of the random family (``--random``), an integer >= 0.
    mesh : MeshSpec
        The emulator mesh the member is drawn for (``--n-rings``/``--n-axial``).
    foam : int or None
        Or the member of the foam family (``--foam``), an integer >= 0.
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

    def __post_init__(self):
        super().__post_init__()
        if self.seed is not None and self.foam is not None:
            name = self.name_of
            raise self.field_error(
                f"{name('seed')} and {name('foam')} name members of two families: give one of them", "seed", "foam"
            )
        if self.seed is None and self.foam is None:
            name = self.name_of
            raise self.field_error(
                f"give {name('seed')} SEED ({RIG} twin:random:SEED) or {name('foam')} SEED ({RIG} twin:foam:SEED)",
                "seed",
                "foam",
                RIG,
            )

    @property
    def family(self) -> str:
        """``"random"`` or ``"foam"``: the family of the member."""
        return "random" if self.foam is None else "foam"

    @property
    def member_seed(self) -> int:
        """The member's seed in its family."""
        return self.seed if self.foam is None else self.foam

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
        MeshSpec(*family.emulator_mesh(robot, self.mesh.n_rings, self.mesh.n_axial)).resolve(robot)
        return family.write(path, robot, self.member_seed, **self.mesh.overrides(), command=command)
