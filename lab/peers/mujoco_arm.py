"""The cable-driven arm in MuJoCo: the same tet mesh as a 3D flex, cables as spatial tendons.

What users would pick instead of our FEM. :func:`mujoco_arm` builds an MJCF model from an
:class:`lab.fem.model.ArmFEM`: one body per free node at its rest position (m), with three
slide joints and the node's lumped mass, the clamped base nodes on the world body; one
``<flex dim="3">`` over our tetrahedra with our Young's modulus and Poisson ratio (equal to
our neo-Hookean law at small strain only), no contacts; each cable a spatial tendon from its
anchor through one site per via point, stiffness ``k`` (N/m) and ``springlength = (0, L0 +
slack - r u)``, so tension-only. Each via point is a site on the body of the node with the
largest barycentric weight in its tet (a site belongs to one body), so its moment arm is that
node's radius and MuJoCo's arm bends less per cable length. The only damping is the flex's
own (``flex_damping_s``, s); the integrator is ``discrete`` (MuJoCo 4 refuses implicit flex).

Why the nearest node rather than an exact embedding, and how damping and integrator were
chosen (measured): docs/design/peers.md.
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from lab.errors import InputError, LabRuntimeError
from lab.fem.model import ArmFEM


def _mujoco():
    try:
        import mujoco
    except ImportError as e:  # a pinned dependency (environment.txt)
        raise LabRuntimeError("lab.peers needs the 'mujoco' package (pinned in environment.txt)") from e
    return mujoco


@contextmanager
def _collect_warnings(sink: list):
    """Route MuJoCo's warning messages into ``sink`` instead of stderr and MUJOCO_LOG.TXT
    (which MuJoCo would write into the working directory)."""
    mujoco = _mujoco()
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda msg: sink.append(msg) if len(sink) < 100 else None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


def _vec(v) -> str:
    return " ".join(f"{x:.17g}" for x in np.ravel(v))


@dataclass
class SettleResult:
    """A settled (or failed) simulation.

    Attributes
    ----------
    status : str
        "settled", "unstable" (non-finite or MuJoCo's bad-acceleration warning) or
        "not_settled" (``max_time_s`` reached).
    sim_time_s : float
        Simulated seconds until the speed stayed below the tolerance.
    wall_s : float
        The wall-clock time (s) spent up to then.
    steps : int
        Steps taken in all.
    max_speed_m_s : float
        The fastest node's speed (m/s) at the last check.
    warnings : int
        MuJoCo warnings raised meanwhile (e.g. an under-converged M+K solve).
    """

    status: str
    sim_time_s: float
    wall_s: float
    steps: int
    max_speed_m_s: float
    warnings: int = 0  # MuJoCo warnings raised meanwhile (e.g. an under-converged M+K solve)


class MujocoArm:
    """A MuJoCo model of an :class:`ArmFEM` (see the module docstring); build with
    :func:`mujoco_arm`. ``model`` and ``fem`` are public.

    Parameters
    ----------
    fem : ArmFEM
        The arm modelled.
    xml : str
        The MJCF model.
    free_nodes : numpy.ndarray
        The mesh nodes (F,) that have a body, in qpos order (3 slide coordinates each,
        displacements in m).
    """

    def __init__(self, fem: ArmFEM, xml: str, free_nodes: np.ndarray):
        mujoco = _mujoco()
        self.fem, self.xml, self.free_nodes = fem, xml, free_nodes
        #: MuJoCo's warning messages so far (the first 100), e.g. an under-converged M + K solve.
        self.warning_messages: list[str] = []
        with _collect_warnings(self.warning_messages):
            self.model = mujoco.MjModel.from_xml_string(xml)
        self._mj = mujoco

    @property
    def n_cables(self) -> int:
        return self.model.ntendon

    def new_data(self):
        """A fresh simulation state at rest.

        Returns
        -------
        mujoco.MjData
            All displacements zero, after a forward pass.
        """
        data = self._mj.MjData(self.model)
        with _collect_warnings(self.warning_messages):
            self._mj.mj_forward(self.model, data)
        return data

    def set_command(self, u_motor) -> None:
        """Set the tendon dead bands (0, L*) for motor angles, L* = L0 + slack - r u (m).

        Parameters
        ----------
        u_motor : array_like
            Motor angles (m,), rad.
        """
        u = np.asarray(u_motor, dtype=float)
        if u.shape != (self.n_cables,):
            raise InputError(f"u_motor must have shape ({self.n_cables},), got {u.shape}")
        self.model.tendon_lengthspring[:, 0] = 0.0
        self.model.tendon_lengthspring[:, 1] = self.fem.cable_targets(u)

    def node_positions(self, data) -> np.ndarray:
        """Positions of all mesh nodes (clamped ones at rest).

        Parameters
        ----------
        data : mujoco.MjData
            A simulation state of this model.

        Returns
        -------
        numpy.ndarray
            x_W (N, 3), m, frame W.
        """
        x = self.fem.X_W.copy()
        x[self.free_nodes] += data.qpos.reshape(-1, 3)
        return x

    def tip(self, data) -> np.ndarray:
        """The tip marker, with our barycentric embedding of the marker.

        Parameters
        ----------
        data : mujoco.MjData
            A simulation state of this model.

        Returns
        -------
        numpy.ndarray
            p_tip_W (3,), m, frame W.
        """
        return self.fem.tip(self.node_positions(data))

    def tendon_lengths(self, data) -> np.ndarray:
        """MuJoCo's tendon lengths.

        Parameters
        ----------
        data : mujoco.MjData
            A simulation state, after a forward pass or step.

        Returns
        -------
        numpy.ndarray
            Lengths (m,), m, one per cable.
        """
        return data.ten_length.copy()

    def settle(self, data, v_tol_m_s: float = 1e-4, hold_s: float = 0.1, max_time_s: float = 10.0) -> SettleResult:
        """Step ``data`` until the fastest node's speed stays below ``v_tol_m_s`` for
        ``hold_s`` simulated seconds (so a turning point of an oscillation does not count).
        ``sim_time_s``/``wall_s`` are taken where that quiet window began.

        Parameters
        ----------
        data : mujoco.MjData
            The state to step (changed in place).
        v_tol_m_s : float
            Speed tolerance (m/s).
        hold_s : float
            How long (simulated s) the speed must stay below it.
        max_time_s : float
            Simulated seconds to give up after.

        Returns
        -------
        SettleResult
            How it ended, with times and steps.
        """
        mj, m = self._mj, self.model
        dt, check = m.opt.timestep, 10  # check every 10 steps (a speed norm costs ~a step)
        bad = int(mj.mjtWarning.mjWARN_BADQACC)
        warn0 = int(data.warning[bad].number)
        all0 = int(sum(w.number for w in data.warning))
        t0 = time.perf_counter()
        steps, quiet_since, quiet_wall, speed = 0, None, 0.0, np.inf
        result = lambda status, s, wall: SettleResult(  # noqa: E731
            status, s * dt, wall, steps, speed, int(sum(w.number for w in data.warning)) - all0
        )
        while steps * dt < max_time_s:
            with _collect_warnings(self.warning_messages):
                mj.mj_step(m, data, nstep=check)
            steps += check
            v = data.qvel.reshape(-1, 3)
            speed = float(np.sqrt(np.max(np.einsum("ij,ij->i", v, v))))
            if not np.isfinite(speed) or int(data.warning[bad].number) > warn0:
                return result("unstable", steps, time.perf_counter() - t0)
            if speed < v_tol_m_s:
                if quiet_since is None:
                    quiet_since, quiet_wall = steps, time.perf_counter() - t0
                if (steps - quiet_since) * dt >= hold_s:
                    return result("settled", quiet_since, quiet_wall)
            else:
                quiet_since = None
        return result("not_settled", steps, time.perf_counter() - t0)


def _via_sites(fem: ArmFEM, body_of_node: dict) -> list[list[tuple[str, np.ndarray]]]:
    """Per cable, (body name, site position in that body's frame) of each via point."""
    sites = []
    for route in fem.cables:
        via = route.points(fem.X_W)[1:]
        rows = []
        for p, nodes, w in zip(via, route.nodes, route.weights):
            n = int(nodes[np.argmax(w)])
            body = body_of_node.get(n)
            rows.append(("world", p) if body is None else (body, p - fem.X_W[n]))
        sites.append(rows)
    return sites


def mujoco_arm(
    fem: ArmFEM,
    *,
    timestep_s: float = 5e-4,
    flex_damping_s: float = 3e-2,
    integrator: str = "discrete",
) -> MujocoArm:
    """Build the MuJoCo model of ``fem``'s arm (mesh, material, gravity, cables; see the
    module docstring). The tendons start at motors 0 (:meth:`MujocoArm.set_command` changes them).

    Parameters
    ----------
    fem : ArmFEM
        Our FEM of the arm, whose mesh, material, gravity and cables are copied; its
        description's ``stiffness_gradient`` must be 0 (a flex has one Young's modulus).
    timestep_s : float
        MuJoCo's time step (s), > 0.
    flex_damping_s : float
        Rayleigh stiffness damping of the flex (s), >= 0.
    integrator : str
        MuJoCo's integrator, "discrete" or "Euler".

    Returns
    -------
    MujocoArm
        The compiled model with its XML and the free nodes (F,) in qpos order.
    """
    if not np.isfinite(timestep_s) or timestep_s <= 0:
        raise InputError(f"timestep_s must be positive, got {timestep_s}")
    if not np.isfinite(flex_damping_s) or flex_damping_s < 0:
        raise InputError(f"flex_damping_s must be >= 0, got {flex_damping_s}")
    if integrator not in ("discrete", "Euler"):
        raise InputError(f"integrator must be 'discrete' or 'Euler' (MuJoCo 4 flex elasticity), got {integrator!r}")
    robot, mesh = fem.robot, fem.mesh
    if np.any(robot.stiffness_gradient):
        raise InputError("a MuJoCo flex has one Young's modulus: the description's stiffness_gradient must be 0")
    free = np.zeros(mesh.n_nodes, bool)
    free[fem.free_dofs[::3] // 3] = True
    free_nodes = np.flatnonzero(free)
    body_of_node = {int(n): f"n{n}" for n in free_nodes}
    bodies = []
    for n in free_nodes:
        m = fem.m_node_kg[n]
        joints = "".join(f'<joint type="slide" axis="{a}"/>' for a in ("1 0 0", "0 1 0", "0 0 1"))
        # Point masses: the inertia is irrelevant without rotational joints, but must be > 0.
        bodies.append(
            f'<body name="n{n}" pos="{_vec(mesh.X_W[n])}">{joints}'
            f'<inertial pos="0 0 0" mass="{m:.17g}" diaginertia="1e-12 1e-12 1e-12"/></body>'
        )
    vert_body = " ".join(body_of_node.get(int(n), "world") for n in range(mesh.n_nodes))
    vert_pos = np.where(free[:, None], 0.0, mesh.X_W)  # world vertices: world coordinates
    sites, tendons = [], []
    for c, (route, rows) in enumerate(zip(fem.cables, _via_sites(fem, body_of_node))):
        sites.append(("world", f"a{c}", route.anchor_W))
        names = [f"a{c}"]
        for k, (body, pos) in enumerate(rows):
            sites.append((body, f"c{c}v{k}", pos))
            names.append(f"c{c}v{k}")
        path = "".join(f'<site site="{s}"/>' for s in names)
        L_star = route.L0_m + route.slack_m
        tendons.append(
            f'<spatial name="cable{c}" stiffness="{robot.cable_stiffness_n_m:.17g}" '
            f'springlength="0 {L_star:.17g}">{path}</spatial>'
        )
    site_xml = {}
    for body, name, pos in sites:
        site_xml.setdefault(body, []).append(f'<site name="{name}" pos="{_vec(pos)}" size="0.001"/>')
    for i, n in enumerate(free_nodes):
        extra = "".join(site_xml.get(f"n{n}", []))
        if extra:
            bodies[i] = bodies[i].replace("</body>", extra + "</body>")
    xml = f"""<mujoco model="{robot.name}">
<option timestep="{timestep_s:.17g}" gravity="{_vec(robot.gravity_m_s2)}" integrator="{integrator}">
<flag contact="disable"/></option>
<worldbody>{"".join(site_xml.get("world", []))}{"".join(bodies)}</worldbody>
<deformable><flex name="arm" dim="3" radius="0.0005" body="{vert_body}" vertex="{_vec(vert_pos)}"
element="{_vec(mesh.tets)}"><contact contype="0" conaffinity="0" selfcollide="none"/>
<elasticity young="{robot.youngs_modulus_pa:.17g}" poisson="{robot.poisson_ratio:.17g}"
damping="{flex_damping_s:.17g}"/></flex></deformable>
<tendon>{"".join(tendons)}</tendon>
</mujoco>"""
    return MujocoArm(fem, xml, free_nodes)
