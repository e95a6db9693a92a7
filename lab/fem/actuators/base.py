"""The actuator interface: what drives the body, as energy in the free coordinates q.

An :class:`Actuator` owns some of the model's inputs u (its :attr:`~Actuator.input_names`,
one unit, bounds) and adds to the total energy E(q, u) its energy, gradient and Hessian in
q, and the mixed derivative d2E/dq du that the sensitivity dq/du = -H^-1 d2E/dq du needs.
Node positions x_W (N, 3) m reach it through the model; it scatters to the free
coordinates with the body's :class:`~lab.fem.bodies.base.FreeCoordinates`.

What it needs from the statics: an actuator whose force is a stiff one-dimensional law
along a few directions (a cable's spring along its length) returns a :class:`Condensation`
from :meth:`Actuator.gradient`, and the Newton steps keep that law exact in those
coordinates (``lab.fem.solve.steps.condensed_step``); a volume-controlled chamber's
fluid is such a law along its volume's gradient, whose stiffness term stays out of the
assembled Hessian (``Condensation.in_hessian``). Others return None.

A new actuator is one module with an :class:`Actuator` subclass decorated with
:func:`register_actuator`; :data:`ACTUATORS` lists them by name.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from lab.errors import InputError

#: Registered actuators, name -> class (see :func:`register_actuator`).
ACTUATORS: dict[str, type] = {}


def register_actuator(name: str):
    """Class decorator registering an :class:`Actuator` subclass under ``name``.

    Parameters
    ----------
    name : str
        The key in :data:`ACTUATORS`, what :class:`lab.fem.model.ArmFEM`'s ``actuators``
        names it by.

    Returns
    -------
    callable
        The decorator; it sets ``cls.kind = name`` and returns the class unchanged.
    """

    def decorate(cls):
        cls.kind = name
        ACTUATORS[name] = cls
        return cls

    return decorate


@dataclass
class Condensation:
    """Coordinates e = A^T dq (k,) along which an actuator's force is a one-dimensional law
    that the Newton steps keep exact.

    Attributes
    ----------
    A : ndarray, shape (n_free, k)
        The directions, m per m.
    stretch : ndarray, shape (k,)
        Where the law is evaluated now, m.
    law : callable
        Stretch (k,) m -> (energy J, force N, stiffness N/m), each (k,).
    scale : float
        The smallest stretch worth resolving, m.
    inputs : slice
        The entries of u the law's stretch moves with.
    gain : float or ndarray, shape (k,)
        d stretch / d u for those inputs, m per unit of u.
    in_hessian : bool
        Whether the actuator's Hessian (:meth:`Actuator.hessian_blocks`) includes the law's
        stiffness term A K A^T (the cables: True). False where that term is dense (a
        chamber's volume couples all its wall's dofs): then the law must be linear
        (constant stiffness K), :meth:`Actuator.hessian_product` still includes it, and the
        statics add it to the factorised Hessian exactly by Woodbury
        (:mod:`lab.fem.solve.steps`).
    values : tuple of ndarray, optional
        ``law(stretch)`` if the actuator evaluated it already (else evaluated once when
        :meth:`at_stretch` is first asked).
    """

    A: np.ndarray
    stretch: np.ndarray
    law: Callable
    scale: float
    inputs: slice
    gain: float | np.ndarray
    in_hessian: bool = True
    values: tuple | None = field(default=None, repr=False, compare=False)

    def at_stretch(self) -> tuple:
        """The law at ``stretch``, evaluated once.

        Returns
        -------
        energy, force, stiffness : ndarray, shape (k,)
            In J, N and N/m (``law(stretch)``).
        """
        if self.values is None:
            self.values = self.law(self.stretch)
        return self.values


class Actuator(ABC):
    """One kind of actuation, built on a body (see :meth:`build`). Subclasses set
    ``input_names`` (tuple of str) and ``input_unit`` (str), and ``condenses = True`` if
    :meth:`gradient` returns a :class:`Condensation`; the model sets ``inputs``, the slice
    of its inputs u this actuator owns."""

    kind: str = ""
    condenses: bool = False
    inputs: slice = slice(0, 0)
    input_names: tuple[str, ...] = ()
    input_unit: str = ""

    @classmethod
    @abstractmethod
    def build(cls, robot, body, free, **options) -> Actuator:
        """The actuator of ``robot`` on ``body``.

        Parameters
        ----------
        robot : RobotDescription
            The description (for what it needs of it).
        body : Body
            The body it acts on (its mesh, markers, :meth:`~lab.fem.bodies.base.Body.embed`).
        free : FreeCoordinates
            The body's free coordinates.
        **options
            The actuator's own settings.

        Returns
        -------
        Actuator
            The actuator.
        """

    @property
    def n_inputs(self) -> int:
        """How many entries of u this actuator owns."""
        return len(self.input_names)

    @abstractmethod
    def input_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The range of each input.

        Returns
        -------
        low, high : ndarray, shape (n_inputs,)
            Bounds in :attr:`input_unit`.
        """

    def check_input(self, u) -> np.ndarray:
        """``u`` as floats, refused (InputError) outside :meth:`input_bounds`.

        Parameters
        ----------
        u : array_like, shape (n_inputs,)
            This actuator's inputs.

        Returns
        -------
        ndarray, shape (n_inputs,)
            The inputs.
        """
        u = np.asarray(u, float).reshape(self.n_inputs)
        low, high = self.input_bounds()
        slack = 1e-9 * np.abs(high - low)  # rounding, as the description's check allows
        bad = ~np.isfinite(u) | (u < low - slack) | (u > high + slack)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"{self.kind} inputs {u.tolist()} {self.input_unit} outside their range: {self.input_names[i]} = "
                f"{u[i]} {self.input_unit}, range [{low[i]}, {high[i]}]"
            )
        return u

    @abstractmethod
    def energy(self, x_W: np.ndarray, u: np.ndarray) -> float:
        """The actuator's energy.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n_inputs,)
            This actuator's inputs.

        Returns
        -------
        float
            Energy, J.
        """

    @abstractmethod
    def gradient(self, x_W: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, Condensation | None]:
        """dE_a/dq and what the statics need.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n_inputs,)
            This actuator's inputs.

        Returns
        -------
        g : ndarray, shape (n_free,)
            The gradient in N.
        condensation : Condensation or None
            The coordinates to keep exact in Newton steps, or None.
        """

    def energy_and_gradient(self, x_W: np.ndarray, u: np.ndarray):
        """:meth:`energy` and :meth:`gradient` together.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n_inputs,)
            This actuator's inputs.

        Returns
        -------
        tuple
            ``(energy (J), g (n_free,) N, condensation or None)``.
        """
        return (self.energy(x_W, u), *self.gradient(x_W, u))

    def block_dofs(self) -> list[np.ndarray]:
        """Mesh dofs (1, 3K) of each dense Hessian block :meth:`hessian_blocks` returns
        (ravelled x, y, z per node), fixed for the model's sparsity pattern.

        Returns
        -------
        list of ndarray
            One (1, 3K) array per block; empty if the Hessian is zero.
        """
        return []

    def hessian_blocks(self, x_W: np.ndarray, u: np.ndarray) -> list[np.ndarray]:
        """d2E_a/dx2 on each block of :meth:`block_dofs`, ravelled (3K * 3K,) in N/m.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n_inputs,)
            This actuator's inputs.

        Returns
        -------
        list of ndarray
            One per block.
        """
        return []

    def hessian_product(self, x_W: np.ndarray, u: np.ndarray) -> Callable:
        """Exact Hessian products without assembly.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n_inputs,)
            This actuator's inputs.

        Returns
        -------
        callable
            ``(acc, v, dx_W) -> acc + d2E_a/dq2 v``, for ``v`` (n_free,) m and the same
            displacement on the nodes ``dx_W`` (N, 3) m; ``acc`` (n_free,) N.
        """
        return lambda acc, v, dx_W: acc

    @abstractmethod
    def mixed_derivative(self, x_W: np.ndarray, u: np.ndarray) -> np.ndarray:
        """How each input changes the forces.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n_inputs,)
            This actuator's inputs.

        Returns
        -------
        ndarray, shape (n_free, n_inputs)
            d2E/dq du, N per unit of each input.
        """

    def input_states(self, x_W: np.ndarray, u: np.ndarray) -> tuple[bool, ...]:
        """Whether each input's actuation is engaged (a cable taut); a warm start that
        flips one whose input did not move is implausible.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n_inputs,)
            This actuator's inputs.

        Returns
        -------
        tuple of bool
            One per input; all True by default.
        """
        return (True,) * self.n_inputs
