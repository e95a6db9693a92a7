"""``python -m lab defects``: the defects file of an emulated as-built robot of a family.

The settings cross in one :class:`lab.asbuilt.member_spec.FamilyMemberSpec`: member SEED of
the family of as-built robots (:mod:`lab.asbuilt.family`: softness, stiffness gradient,
eyelet shifts, slack, play, lag, motors, motion capture) or of the foam family
(:mod:`lab.asbuilt.foam`: the same in-class defects plus the hyperfoam law, cable
stiffness, creep, a tilted base, the mocap's frame error and a finer emulator mesh), and
the emulator mesh. :func:`run` draws it for a robot description (any number of cables)
and writes it atomically as a commented defects file in the format of
``lab/rig/defects/``; the same seed always gives the same file, usable as ``--rig
twin:FILE``.
"""

from __future__ import annotations

from lab.asbuilt.member_spec import FamilyMemberSpec

__all__ = ["run"]


def run(spec: FamilyMemberSpec, robot, out, *, command: str | None = None):
    """Write ``spec``'s member for ``robot`` to the defects file ``out``.

    Parameters
    ----------
    spec : FamilyMemberSpec
        Which member of which family, and the emulator mesh.
    robot : RobotDescription
        The robot description the member is drawn for.
    out : str or Path
        Output defects file (TOML), written atomically.
    command : str, optional
        The command that makes the same file, recorded in its header.

    Returns
    -------
    Defects
        The member's :class:`lab.asbuilt.arm.Defects` as written. A mesh that would not fit
        in memory is refused (InputError) before anything is written.
    """
    return spec.write(out, robot, command=command)
