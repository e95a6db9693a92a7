"""``MocapScene``: what the emulated cameras see, and where the robot's frame W sits among them.

The NatNet server emulator (:mod:`.natnet_server`) streams the tip marker and the base
markers of a scene: their names (the marker set, the tip marker, the base markers and an
optional rigid body on the tip), the base markers' positions in W, the placement of W in the
mocap frame M (``p_M = R_MW p_W + t_MW_m``, by default Motive's Y-up frame turned 30 degrees
about the vertical and offset) and the streamed length unit (m or mm). The hardware rig's
calibration must recover that placement from the base markers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def _rotation_z_up_to_y_up(yaw_deg: float) -> np.ndarray:
    """W (z up) into a Y-up mocap frame, turned by ``yaw_deg`` about the vertical."""
    to_y_up = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    yaw = np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])
    return yaw @ to_y_up


@dataclass(frozen=True)
class MocapScene:
    """What the cameras see: marker names, the base markers' positions in W (m), the
    placement of W in the mocap frame M (``p_M = R_MW p_W + t_MW_m``) and the unit.

    Attributes
    ----------
    marker_set : str
        Name of the marker set that holds the tip and base markers.
    tip_marker : str
        Name of the tip marker.
    base_markers : tuple of str
        Names of the base markers.
    base_positions_W_m : tuple
        The base markers' positions, one (x, y, z) per marker, in m in W.
    R_MW : numpy.ndarray
        Rotation of W into the mocap frame M, shape (3, 3).
    t_MW_m : tuple
        Origin of W in M, (3,), in m.
    tip_rigid_body : tuple or None
        (name, id) of a rigid body on the tip, or None for none.
    marker_set_model_id : int
        Model id of the marker set (the high 16 bits of its labeled markers' ids).
    length_unit_m : float
        The streamed length unit in m: 1.0 streams metres, 1e-3 millimetres.
    """

    marker_set: str = "soft_arm"
    tip_marker: str = "tip"
    base_markers: tuple = ("base_1", "base_2", "base_3")
    base_positions_W_m: tuple = ((-0.01, 0.03, 0.03), (-0.01, -0.035, 0.02), (-0.01, 0.0, -0.04))
    R_MW: np.ndarray = field(default_factory=lambda: _rotation_z_up_to_y_up(30.0))
    t_MW_m: tuple = (0.40, 0.90, -0.20)
    tip_rigid_body: tuple | None = ("tip_body", 7)  # (name, id) or None
    marker_set_model_id: int = 1
    length_unit_m: float = 1.0  # 1e-3 streams millimetres

    def to_mocap(self, p_W_m: np.ndarray) -> np.ndarray:
        """Points of W in the mocap frame M, in the streamed unit.

        Parameters
        ----------
        p_W_m : numpy.ndarray
            Points, shape (k, 3) (or (3,) for one), in m in W.

        Returns
        -------
        numpy.ndarray
            The points in M, shape (k, 3), in the streamed unit (``length_unit_m`` m).
        """
        return (np.atleast_2d(p_W_m) @ self.R_MW.T + np.asarray(self.t_MW_m)) / self.length_unit_m

    @property
    def marker_names(self) -> list[str]:
        """The tip marker, then the base markers."""
        return [self.tip_marker, *self.base_markers]
