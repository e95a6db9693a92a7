"""Which emulated as-built robot of the family: :class:`FamilyMemberSpec`, the ``defects`` settings.

A member of the family (:mod:`lab.rig.family`) is named by its seed (``--random SEED``, the
same as ``--rig twin:random:SEED``) and drawn for the emulator mesh it will run on
(:class:`lab.fem.MeshSpec`, ``--n-rings``/``--n-axial``, written to the file's
``[emulator]`` table). :meth:`FamilyMemberSpec.write` writes its defects file.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from lab.fem.mesh_spec import MeshSpec
from lab.specs import Spec, non_negative_int, option

__all__ = ["FamilyMemberSpec"]


@dataclass(frozen=True)
class FamilyMemberSpec(Spec):
    """Member ``seed`` of the family of as-built robots, on the emulator mesh ``mesh``."""

    seed: int = option(
        None,
        flag="--random",
        type=int,
        metavar="SEED",
        required=True,
        check=non_negative_int,
        help="the robot of the family to draw (an integer >= 0; the same as --rig twin:random:SEED)",
    )
    mesh: MeshSpec = field(default_factory=MeshSpec)

    def write(self, path, robot, command: str | None = None):
        """Write the member's commented defects file for ``robot`` to ``path`` (atomically);
        returns its :class:`lab.rig.asbuilt.Defects`. A mesh that would not fit in memory
        is refused here (InputError), not first by the command that runs the emulator."""
        from lab.rig.family import write_random_defects

        self.mesh.resolve(robot)
        return write_random_defects(path, robot, self.seed, **self.mesh.overrides(), command=command)
