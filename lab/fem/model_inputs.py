"""The inputs and actuators of the assembled model (:class:`lab.fem.model.ArmFEM`).

Builds the actuators from their registry (:data:`lab.fem.actuators.ACTUATORS`), each owning
the next slice of the inputs u, and answers for them together: names, checks, split, which
are engaged. The description's cables are reachable by name (:meth:`ActuatedModel.cables`
and friends) for the code that draws or ports them.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.fem.actuators import ACTUATORS
from lab.fem.actuators.cable_routes import spring


def description_actuators(robot) -> list:
    """The actuators of a description's cables and chambers, each owning its inputs.

    ``["cables"]`` when every input is an angle-controlled cable (today's robots),
    ``["tendons_tension"]`` when all are tension-controlled cables, ``["chambers_pressure"]``
    or ``["chambers_volume"]`` when all are chambers of one control; else one actuator per
    kind present, each with the indices of its cables (``cables``) or chambers
    (``chambers``), whose inputs sit at those places in u (cables first, then chambers).

    Parameters
    ----------
    robot : RobotDescription
        The description.

    Returns
    -------
    list
        Actuator names or ``(name, options)`` pairs for :class:`lab.fem.model.ArmFEM`.
    """
    chambers = getattr(robot, "chambers", ())
    groups = [
        ("cables", "cables", [i for i, c in enumerate(robot.cables) if c.control == "angle"]),
        ("tendons_tension", "cables", [i for i, c in enumerate(robot.cables) if c.control == "tension"]),
        ("chambers_pressure", "chambers", [j for j, c in enumerate(chambers) if c.control == "pressure"]),
        ("chambers_volume", "chambers", [j for j, c in enumerate(chambers) if c.control == "volume"]),
    ]
    present = [(name, key, idx) for name, key, idx in groups if idx]
    if len(present) == 1:
        return [present[0][0]]
    return [(name, {key: idx}) for name, key, idx in present]


def description_inputs(robot, options: dict) -> np.ndarray:
    """Where in u the inputs of one of :func:`description_actuators`' actuators sit.

    Parameters
    ----------
    robot : RobotDescription
        The description.
    options : dict
        The actuator's options: ``cables`` (cable indices) or ``chambers`` (chamber indices).

    Returns
    -------
    ndarray of int
        Input indices (cables first in u, then the chambers).
    """
    if "cables" in options:
        return np.asarray(options["cables"], dtype=np.int64)
    return robot.n_cables + np.asarray(options["chambers"], dtype=np.int64)


class ActuatedModel:
    """The actuator half of :class:`lab.fem.model.ArmFEM` (it sets ``robot``, ``body``,
    ``coordinates`` and ``free_dofs``, then calls :meth:`_build_actuators`)."""

    def _build_actuators(self, specs, cable_slack_m) -> list:
        scattered = specs is None  # the description's own: each cable's input at its place in the file
        specs = description_actuators(self.robot) if specs is None else specs
        built, start = [], 0
        for spec in specs:
            name, options = (spec, {}) if isinstance(spec, str) else spec
            if name not in ACTUATORS:
                raise InputError(f"unknown actuator {name!r}; registered: {sorted(ACTUATORS)}")
            if name == "cables":  # the description's cables: their slack and this model's spring law
                options = {"slack_m": cable_slack_m, "law": self.cable_springs} | dict(options)
            act = ACTUATORS[name].build(self.robot, self.body, self.coordinates, **options)
            if scattered and len(specs) > 1:
                act.inputs = description_inputs(self.robot, options)
            else:
                act.inputs = slice(start, start + act.n_inputs)
            start += act.n_inputs
            built.append(act)
        self.checks_description = scattered
        if sum(getattr(a, "condenses", False) for a in built) > 1:
            raise InputError("at most one actuator may ask the statics for a condensation")
        self.n_inputs = start
        return built

    @property
    def input_names(self) -> tuple[str, ...]:
        """Names of the inputs u, actuator by actuator."""
        return tuple(n for a in self.actuators for n in a.input_names)

    def check_input(self, u) -> np.ndarray:
        """The inputs u (n_inputs,) as floats, each actuator's slice checked by it.

        Parameters
        ----------
        u : array_like, shape (n_inputs,)
            All inputs.

        Returns
        -------
        ndarray, shape (n_inputs,)
            The inputs (InputError if one is refused).
        """
        if len(self.actuators) == 1:
            return self.actuators[0].check_input(u)
        if self.checks_description:  # mixed control: each input's range and the safety rules
            return self.robot.check_command(u)
        u = np.asarray(u, dtype=float)
        if u.shape != (self.n_inputs,):
            raise InputError(f"expected {self.n_inputs} inputs {list(self.input_names)}, got shape {u.shape}")
        return np.concatenate([a.check_input(u[a.inputs]) for a in self.actuators] + [np.zeros(0)])

    def _split(self, u):
        u = np.asarray(u, dtype=float)
        return [(a, u[a.inputs]) for a in self.actuators]

    def input_states(self, q: np.ndarray, u) -> tuple[bool, ...]:
        """Whether each input's actuation is engaged (e.g. a cable taut) at ``q``.

        Parameters
        ----------
        q : ndarray, shape (n_free,)
            Free coordinates, m.
        u : array_like, shape (n_inputs,)
            Inputs.

        Returns
        -------
        tuple of bool
            One per input.
        """
        x = self.to_nodes(q)
        return tuple(s for act, u_a in self._split(u) for s in act.input_states(x, u_a))

    # ---------------------------------------------------------------- the description's cables
    def actuator(self, kind: str):
        """The first actuator of kind ``kind`` (a name in :data:`~lab.fem.actuators.ACTUATORS`).

        Parameters
        ----------
        kind : str
            E.g. ``"cables"``.

        Returns
        -------
        Actuator
            The actuator (KeyError if the model has none of that kind).
        """
        for act in self.actuators:
            if act.kind == kind:
                return act
        raise KeyError(f"no {kind!r} actuator in this model (it has {[a.kind for a in self.actuators]})")

    @property
    def cables(self) -> list:
        """The cables' routes (:class:`~lab.fem.actuators.cable_routes.CableRoute`)."""
        return self.actuator("cables").routes

    def cable_lengths(self, x_W) -> np.ndarray:
        """Length of each cable (m,) in m at node positions ``x_W`` (N, 3) m."""
        return self.actuator("cables").lengths(x_W)

    def cable_targets(self, u_motor) -> np.ndarray:
        """Free length L* = L0 + slack - r u of each cable (m,) in m for angles ``u_motor`` rad."""
        return self.actuator("cables").targets(u_motor)

    def cable_tensions(self, x_W, u_motor) -> np.ndarray:
        """Tension of each cable (m,) in N at node positions ``x_W`` (N, 3) m."""
        return self.actuator("cables").tensions(x_W, u_motor)

    def cable_springs(self, stretch_m):
        """The cables' spring law: energy (J), tension (N) and stiffness (N/m) of each cable
        (m,) at stretches d = L - L* (m,) m; the description's one-sided spring (a subclass
        may change it, e.g. cables that stretch themselves).

        Parameters
        ----------
        stretch_m : array_like, shape (m,) or scalar
            Stretches, m.

        Returns
        -------
        energy, tension, stiffness : ndarray
            Shaped as ``stretch_m``.
        """
        return spring(stretch_m, self.robot.cable_stiffness_n_m, self.robot.slack_smoothing_m)

    def mixed_derivative(self, q: np.ndarray, u) -> np.ndarray:
        """d2E/dq du (n_free, n_inputs): how each input changes the forces (N per unit of u).

        Parameters
        ----------
        q : ndarray, shape (n_free,)
            Free coordinates, m.
        u : array_like, shape (n_inputs,)
            Inputs.

        Returns
        -------
        ndarray, shape (n_free, n_inputs)
            The mixed derivative.
        """
        x = self.to_nodes(q)
        if len(self.actuators) == 1:
            return self.actuators[0].mixed_derivative(x, np.asarray(u, dtype=float))
        out = np.zeros((self.n_free, self.n_inputs))
        for act, u_a in self._split(u):
            out[:, act.inputs] = act.mixed_derivative(x, u_a)
        return out
