"""Robot descriptions: a TOML file -> a validated, immutable :class:`RobotDescription`.

A description says everything the simulator needs about a tendon-, cable- or fluid-driven
soft robot: its body (a cylinder, a tapered solid of revolution, or a mesh or CAD file),
material (neo-Hookean foam or Yeoh silicone), mounting (gravity), mesh resolution, actuation
(spool radius, motor range, cable spring), the cables' routes through eyelets and how each is
controlled (spool angle or tension), the fluid chambers (pressure or volume), the tip marker
and further markers, and the safety rule that forbids too-aggressive commands.

Shipped descriptions live in ``lab/robots/<name>.toml``; :func:`load_robot` accepts either
such a name (``"three-cable"``) or a path to a user's own file. Every field is checked and a
bad file raises :class:`DescriptionError` naming the file and the field.

Optional as-built fields (``python -m lab calibrate`` writes them; absent, nothing changes,
not even :attr:`RobotDescription.sha256`): ``material.stiffness_gradient = [0, g_y, g_z]``,
E(p) = youngs_modulus_pa (1 + g . p / radius_m), |g| < 1; ``cables[].slack_m``, free length
beyond taut at rest in m (negative: pre-tensioned), within +-10 % of the body length.
"""

from lab.description.chambers import Chamber
from lab.description.fields import ROBOT_FIELDS, check_fields
from lab.description.load import ROBOTS_DIR, load_robot, read_toml, shipped_robots
from lab.description.parse import parse_robot
from lab.description.robot import (
    FORMAT_VERSION,
    BodyShape,
    Cable,
    DescriptionError,
    MarkerSpec,
    RobotDescription,
    SafetyLimit,
)

__all__ = [
    "FORMAT_VERSION",
    "ROBOTS_DIR",
    "ROBOT_FIELDS",
    "BodyShape",
    "Cable",
    "Chamber",
    "DescriptionError",
    "MarkerSpec",
    "RobotDescription",
    "SafetyLimit",
    "check_fields",
    "load_robot",
    "parse_robot",
    "read_toml",
    "shipped_robots",
]
