"""``python -m lab fit-dynamics``: the foam's relaxation filter of a rig from step responses
and short random motions.

:func:`run` takes the command's :class:`lab.capture.dynamics_probe.ProbeSpec` (how many steps,
how long held, how many random motions, how many modes): it plans the excitation for the
robot and the seed (:meth:`lab.capture.dynamics_probe.ProbeSpec.plan`), drives the rig through it while the motion
capture is recorded (:func:`lab.capture.dynamics_probe.run_probe` on :func:`lab.rig.make_rig`),
fits ``modes`` relaxation modes (time constants and weights) and every command's
equilibrium to the recording (:func:`lab.dynamics.relaxation_fit.fit_stream`), and writes
the filter (:meth:`lab.dynamics.relaxation.Relaxation.save`, kind ``lab.dynamics``) with
the robot, the rig's description, the plan, the command line and the fit's RMS residual
in its metadata. ``track --period-s T --dynamic-model DYN.npz`` inverts it into a
feed-forward command.
"""

from __future__ import annotations

from collections.abc import Callable

from lab.capture.dynamics_probe import ProbeSpec
from lab.fem.bodies.mesh_spec import MeshSpec
from lab.rig.spec import RigSpec

__all__ = ["run"]


def run(
    probe: ProbeSpec,
    rig: RigSpec | str,
    robot,
    out,
    *,
    seed: int = 0,
    mesh: MeshSpec | None = None,
    command: str = "",
    say: Callable | None = None,
):
    """Drive ``rig`` through ``probe``'s excitation, fit the relaxation filter and write it to ``out``.

    Parameters
    ----------
    probe : ProbeSpec
        The excitation (steps, holds, random motions) and the number of modes fitted.
    rig : RigSpec or str
        A rig with dynamics: a twin or hardware (``sim`` has none); a ``--rig`` string is
        parsed by :meth:`lab.rig.RigSpec.parse`, and named as given in the first line said.
    robot : RobotDescription
        The robot on the rig.
    out : str or Path
        The dynamic model file (.npz).
    seed : int
        Seed of the random commands (and of an emulated rig's noise).
    mesh : MeshSpec, optional
        FEM mesh of an emulated twin (None: its own).
    command : str
        The command line, recorded in the file's metadata.
    say : callable, optional
        Called with each line the user should read (the plan, the fit); default silent.

    Returns
    -------
    relax : Relaxation
        The fitted filter (:class:`lab.dynamics.relaxation.Relaxation`), as written.
    report : dict
        The fit's report (``rms_m``, ``n_readings``, ``equilibria``, ...).
    """
    from lab.capture.dynamics_probe import plan_info, run_probe
    from lab.dynamics.relaxation_fit import fit_stream
    from lab.rig import make_rig

    say = say or (lambda line: None)
    plan = probe.plan(robot, seed)
    say(
        f"{robot.name} on {rig}: {probe.n_steps} steps held {probe.step_hold_s:g} s and {probe.n_random} "
        f"random motions, {plan.duration_s:.0f} s of holds"
    )
    with make_rig(rig, robot, seed=seed, mesh=mesh) as live:
        describe = live.describe()
        stream = run_probe(live, plan)
    relax, report = fit_stream(stream, probe.modes)
    relax.save(
        out,
        robot=robot.name,
        robot_sha256=robot.sha256,
        rig=describe,
        plan=plan_info(plan),
        fit={"rms_m": report["rms_m"], "n_readings": report["n_readings"], "n_poses": len(report["equilibria"])},
        pace=stream.pace,
        command=command,
    )
    modes = ", ".join(f"tau {t:.3f} s weight {w:.3f}" for t, w in zip(relax.tau_s, relax.weight))
    say(
        f"{len(relax.tau_s)} modes: {modes}; fit RMS {1e3 * report['rms_m']:.3f} mm over {report['n_readings']} "
        f"readings, noise {1e3 * relax.noise_sigma_m:.3f} mm per frame, motion capture read at "
        f"{stream.pace['achieved_rate_hz']:.1f} Hz of {stream.pace['nominal_rate_hz']:g} Hz -> {out}"
    )
    return relax, report
