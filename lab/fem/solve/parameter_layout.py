"""Where each as-built parameter sits in theta, the vector :class:`ParametrisedFEM` takes.

theta (p,) = ``[ln s, g_y, g_z, delta_1, ..., delta_m, sigma_1, ..., sigma_m]``: log softness,
stiffness gradient (dimensionless), the eyelet shift of each of the m cables (m; a = 2 axes
(y, z) or 3 (x, y, z) of frame W) and each cable's slack (m), so p = 3 + (a + 1) m.
:class:`ParameterLayout` packs and unpacks it by name; :class:`ParameterError` refuses a
theta outside the model. What each parameter means: :mod:`lab.fem.solve.parameters`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError

#: The axes (of frame W) of each eyelet-shift option.
AXES = {"yz": (1, 2), "xyz": (0, 1, 2)}


class ParameterError(InputError):
    """Parameters outside the model: ``|g| >= 1``, an eyelet shifted out of the mesh, non-finite."""


@dataclass(frozen=True)
class ParameterLayout:
    """Where each parameter sits in theta, for the cables ``cable_names`` and shift ``axes``.

    Attributes
    ----------
    cable_names : tuple of str
        The m cables, in the description's order.
    axes : str
        The axes of frame W the eyelet shifts move along: ``"yz"`` (a = 2) or ``"xyz"`` (a = 3).
    """

    cable_names: tuple[str, ...]
    axes: str = "yz"

    def __post_init__(self):
        if self.axes not in AXES:
            raise InputError(f"eyelet-shift axes must be one of {sorted(AXES)}, got {self.axes!r}")

    @property
    def n_cables(self) -> int:
        """Number of cables m."""
        return len(self.cable_names)

    @property
    def size(self) -> int:
        """p = 3 + (a + 1) m."""
        return 3 + (len(AXES[self.axes]) + 1) * self.n_cables

    def shift(self, c: int) -> slice:
        """Where cable ``c``'s eyelet shift sits in theta.

        Parameters
        ----------
        c : int
            The cable's index.

        Returns
        -------
        slice
            The (a,) entries of theta holding its shift, m.
        """
        a = len(AXES[self.axes])
        return slice(3 + a * c, 3 + a * (c + 1))

    @property
    def slack(self) -> slice:
        """The (m,) entries of theta holding the cables' slack, m."""
        return slice(self.size - self.n_cables, self.size)

    @property
    def names(self) -> list[str]:
        """One name per parameter, e.g. ``via_shift_y_m[top]``."""
        out = ["log_softness", "gradient_y", "gradient_z"]
        out += [f"via_shift_{'xyz'[i]}_m[{n}]" for n in self.cable_names for i in AXES[self.axes]]
        return out + [f"slack_m[{n}]" for n in self.cable_names]

    @property
    def units(self) -> list[str]:
        """The unit of each parameter (``"1"`` or ``"m"``)."""
        return ["1"] * 3 + ["m"] * (self.size - 3)

    def pack(self, softness=1.0, gradient=(0.0, 0.0), via_shift_m=None, slack_m=None) -> np.ndarray:
        """theta (p,) from softness s > 0, gradient (g_y, g_z), shifts (m, 3) m in frame W and
        slack (m,) m. A shift along an axis the layout does not hold must be zero.

        Parameters
        ----------
        softness : float
            s = E_as-built / E (> 0).
        gradient : array_like, shape (2,)
            Stiffness gradient (g_y, g_z), dimensionless.
        via_shift_m : array_like, shape (m, 3), optional
            Eyelet shift of each cable in frame W, m; default none.
        slack_m : array_like, shape (m,), optional
            Slack of each cable, m; default none.

        Returns
        -------
        ndarray, shape (p,)
            theta (ParameterError for a shift along an axis not held).
        """
        m, axes = self.n_cables, AXES[self.axes]
        shift = np.zeros((m, 3)) if via_shift_m is None else np.asarray(via_shift_m, float).reshape(m, 3)
        dropped = [i for i in range(3) if i not in axes]
        if np.any(shift[:, dropped]):
            raise ParameterError(f"eyelet shifts along x need axes='xyz', got {shift.tolist()}")
        slack = np.zeros(m) if slack_m is None else np.asarray(slack_m, float).reshape(m)
        return np.concatenate(
            [[np.log(softness)], np.asarray(gradient, float).reshape(2), shift[:, axes].ravel(), slack]
        )

    def unpack(self, theta) -> dict:
        """The parameters of theta by name.

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters (module docstring).

        Returns
        -------
        dict
            ``softness`` (float), ``gradient`` (2,), ``via_shift_m`` (m, 3) m in frame W and
            ``slack_m`` (m,) m (ParameterError for a theta of another size).
        """
        theta = np.asarray(theta, float)
        if theta.shape != (self.size,):
            raise ParameterError(f"expected {self.size} parameters ({', '.join(self.names)}), got shape {theta.shape}")
        shift = np.zeros((self.n_cables, 3))
        shift[:, AXES[self.axes]] = theta[3 : self.slack.start].reshape(self.n_cables, -1)
        return {
            "softness": float(np.exp(theta[0])),
            "gradient": theta[1:3].copy(),
            "via_shift_m": shift,
            "slack_m": theta[self.slack].copy(),
        }
