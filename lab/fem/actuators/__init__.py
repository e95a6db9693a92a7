"""Actuators: what drives the body, each as energy in the free coordinates and its inputs.

:class:`Actuator` is the interface and :class:`Condensation` what an actuator may ask of the
statics (:mod:`.base`); :class:`CableActuator` is the description's angle-controlled cables
(:mod:`.cables`, on the cable geometry of :mod:`.cable_routes`); :mod:`.tension` drives the
same cables as tendons by their tensions (``"tendons_tension"``); :mod:`.chamber` holds
cavities of the body at gauge pressures (``"chambers_pressure"``, :class:`PressureChamberActuator`,
on the cavities :func:`cavity_surfaces` finds, :mod:`.chamber_surfaces`) or fills them with given
fluid volumes (``"chambers_volume"``, :class:`VolumeChamberActuator`, :mod:`.chamber_volume`). A new
actuator is one module
with an :class:`Actuator` subclass decorated with :func:`register_actuator`, imported once
(then :class:`lab.fem.ArmFEM` builds it by name).
"""

from lab.fem.actuators import tension  # noqa: F401  (registers "tendons_tension")
from lab.fem.actuators.base import ACTUATORS, Actuator, Condensation, register_actuator
from lab.fem.actuators.cable_routes import CableRoute, spring
from lab.fem.actuators.cables import CableActuator
from lab.fem.actuators.chamber import PressureChamberActuator
from lab.fem.actuators.chamber_surfaces import cavity_surfaces
from lab.fem.actuators.chamber_volume import VolumeChamberActuator

__all__ = [
    "ACTUATORS",
    "Actuator",
    "Condensation",
    "register_actuator",
    "CableActuator",
    "CableRoute",
    "PressureChamberActuator",
    "VolumeChamberActuator",
    "cavity_surfaces",
    "spring",
]
