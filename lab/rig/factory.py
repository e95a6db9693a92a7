"""The one way to build a rig: :func:`make_rig` from a :class:`~lab.rig.spec.RigSpec` (or its string).

A command never builds a :class:`~lab.rig.sim.SimRig` or a twin by hand: it hands
:func:`make_rig` the spec, and the FEM (a ``sim`` rig on the FEM the command already built)
or the mesh (a coarse emulated twin for quick runs) when it has one.
:func:`as_built_body` is the emulated as-built arm of a twin spec without the rig around it,
for studies that read its quasi-static map directly.
"""

from __future__ import annotations

from lab.description import RobotDescription
from lab.errors import FieldError
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.fem.model import ArmFEM
from lab.rig.base import Rig
from lab.rig.spec import RIG, RigSpec

__all__ = ["make_rig", "as_built_body"]


def _spec(spec: RigSpec | str, mesh: MeshSpec | None) -> RigSpec:
    return RigSpec.parse(spec, mesh=mesh)


def as_built_body(spec: RigSpec | str, robot: RobotDescription, *, mesh: MeshSpec | None = None):
    """The emulated as-built arm of a ``twin`` spec, without the rig around it.

    Parameters
    ----------
    spec : RigSpec or str
        A ``twin`` spec: its defects file, the shipped defects, or member SEED of the
        ``random``, ``foam`` or ``pneumatic`` family (:data:`lab.asbuilt.FAMILIES`) drawn for the mesh.
    robot : RobotDescription
        The nominal robot.
    mesh : MeshSpec or None
        FEM mesh overrides replacing the spec's (a foam member's own, finer mesh where
        neither sets one).

    Returns
    -------
    AsBuiltBody or PneumaticBody
        The body (:func:`lab.rig.twin.emulated_body`: pressure regulators for a robot with
        chambers); InputError for a spec of another kind.
    """
    spec = _spec(spec, mesh)
    if spec.kind != "twin":
        raise FieldError(f"{RIG} {spec}: an as-built body is emulated for {RIG} twin only", RIG)
    from lab.rig.twin import emulated_body

    overrides = spec.mesh.overrides()
    if spec.family_seed is not None:
        from lab.asbuilt.family import FAMILIES

        defects = FAMILIES[spec.family].defects(robot, spec.family_seed, **overrides)
        return emulated_body(robot, defects, **overrides)
    return emulated_body(robot, spec.defects_path, **overrides)


def make_rig(
    spec: RigSpec | str,
    robot: RobotDescription,
    *,
    seed: int = 0,
    fem: ArmFEM | None = None,
    mesh: MeshSpec | None = None,
) -> Rig:
    """The rig of ``spec`` (a :class:`RigSpec` or a ``--rig`` string) for ``robot``.

    Parameters
    ----------
    spec : RigSpec or str
        The rig, as a spec or a ``--rig`` string.
    robot : RobotDescription
        The nominal robot.
    seed : int
        The emulated robot's motion-capture noise seed (``twin:random:SEED`` or
        ``twin:foam:SEED`` picks the robot of the family; ``seed`` still only the noise).
    fem : ArmFEM or None
        The nominal FEM a ``sim`` rig solves (default: built on the spec's mesh).
    mesh : MeshSpec or None
        FEM mesh overrides of a ``sim`` or ``twin`` rig, replacing the spec's.

    Returns
    -------
    Rig
        A :class:`~lab.rig.sim.SimRig`, :class:`~lab.rig.twin.TwinRig` (or
        :class:`~lab.rig.twin.FamilyTwinRig`) or :class:`~lab.rig.hardware.HardwareRig`.
        Raises InputError (a ValueError) naming the problem: a bad spec, ``none`` (no rig),
        an FEM for a rig that is not ``sim``, an FEM and a mesh together, a mesh for a
        hardware rig.
    """
    spec = _spec(spec, mesh)
    if not spec.has_rig:
        raise FieldError(
            f"{RIG} none is no rig: only `track` takes {RIG} none, to solve the IK and write the commands", RIG
        )
    if fem is not None and spec.kind != "sim":
        raise FieldError(f"{RIG} {spec}: only {RIG} sim runs on a given nominal FEM", RIG)
    if spec.kind == "sim":
        from lab.rig.sim import SimRig

        if fem is not None and not spec.mesh.is_default:
            raise FieldError(f"{RIG} sim: give the FEM or the mesh overrides, not both", RIG)
        return SimRig(robot, fem if fem is not None else ArmFEM(robot, **spec.mesh.overrides()))
    if spec.kind == "twin":
        if spec.family_seed is not None:
            from lab.asbuilt.family import FAMILIES
            from lab.rig.twin import FamilyTwinRig

            family = FAMILIES[spec.family]
            return FamilyTwinRig(robot, spec.family_seed, seed=seed, family=family, **spec.mesh.overrides())
        from lab.rig.twin import TwinRig

        return TwinRig(robot, seed=seed, body=as_built_body(spec, robot))
    from lab.rig.hardware import HardwareRig

    return HardwareRig.from_config(spec.config_path, robot)
