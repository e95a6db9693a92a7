"""Where each as-built parameter sits in theta, the vector :class:`ParametrisedFEM` takes.

theta (p,) holds the fitted groups, always in this order: ``softness`` (log softness ln s,
1 entry), ``gradient`` (stiffness gradient g_y, g_z, dimensionless), ``eyelets`` (the eyelet
shift of each of the m cables, m; a = 2 axes (y, z) or 3 (x, y, z) of frame W), ``slack``
(the slack of each angle-controlled cable, m) and ``density`` (theta_rho, the factor on the
description's density, 1 entry). The default groups are the first four, so with every cable
angle-controlled theta = ``[ln s, g_y, g_z, delta_1, ..., delta_m, sigma_1, ..., sigma_m]``
and p = 3 + (a + 1) m. :class:`ParameterLayout` packs and unpacks it by name;
:class:`ParameterError` refuses a theta outside the model. What each parameter means:
:mod:`lab.fem.solve.parameters`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lab.errors import InputError

#: The axes (of frame W) of each eyelet-shift option.
AXES = {"yz": (1, 2), "xyz": (0, 1, 2)}
#: The parameter groups a fit may hold, in theta's order.
GROUPS = ("softness", "gradient", "eyelets", "slack", "density")
#: The groups fitted by default (for angle-controlled cables).
DEFAULT_GROUPS = ("softness", "gradient", "eyelets", "slack")


class ParameterError(InputError):
    """Parameters outside the model: ``|g| >= 1``, an eyelet shifted out of the mesh, non-finite."""


def parse_groups(text) -> tuple[str, ...]:
    """Fit groups from a comma-separated text (or a sequence), in theta's order.

    Parameters
    ----------
    text : str or sequence of str
        E.g. ``"softness,density"``.

    Returns
    -------
    tuple of str
        The groups, each once, in the order of :data:`GROUPS` (InputError naming an
        unknown group and the valid ones, or for none).
    """
    names = [t.strip() for t in (text.split(",") if isinstance(text, str) else text)]
    unknown = [n for n in names if n not in GROUPS]
    if unknown:
        raise InputError(f"unknown fit group {unknown[0]!r}; valid groups: {', '.join(GROUPS)}")
    if not names:
        raise InputError(f"no fit group given; valid groups: {', '.join(GROUPS)}")
    return tuple(g for g in GROUPS if g in names)


@dataclass(frozen=True)
class ParameterLayout:
    """Where each parameter sits in theta, for the cables ``cable_names`` and shift ``axes``.

    Attributes
    ----------
    cable_names : tuple of str
        The m cables, in the description's order.
    axes : str
        The axes of frame W the eyelet shifts move along: ``"yz"`` (a = 2) or ``"xyz"`` (a = 3).
    groups : tuple of str
        The fitted groups (:data:`GROUPS`, in that order); default :data:`DEFAULT_GROUPS`.
    slack_cables : tuple of int, optional
        The cables with a slack (the angle-controlled ones); default all.
    """

    cable_names: tuple[str, ...]
    axes: str = "yz"
    groups: tuple[str, ...] = DEFAULT_GROUPS
    slack_cables: tuple[int, ...] | None = None

    def __post_init__(self):
        if self.axes not in AXES:
            raise InputError(f"eyelet-shift axes must be one of {sorted(AXES)}, got {self.axes!r}")
        if tuple(self.groups) != parse_groups(self.groups):
            raise InputError(f"fit groups must be distinct and in the order {', '.join(GROUPS)}, got {self.groups}")

    @property
    def n_cables(self) -> int:
        """Number of cables m."""
        return len(self.cable_names)

    @property
    def slack_indices(self) -> tuple[int, ...]:
        """The cables that have a slack (indices)."""
        return tuple(range(self.n_cables)) if self.slack_cables is None else tuple(self.slack_cables)

    def _sizes(self) -> dict:
        a = len(AXES[self.axes])
        full = {"softness": 1, "gradient": 2, "eyelets": a * self.n_cables, "slack": len(self.slack_indices)}
        return {g: (full | {"density": 1})[g] if g in self.groups else 0 for g in GROUPS}

    def block(self, group: str) -> slice:
        """Where group ``group`` sits in theta (an empty slice when it is not fitted).

        Parameters
        ----------
        group : str
            One of :data:`GROUPS`.

        Returns
        -------
        slice
            Its entries of theta.
        """
        start = 0
        for g, n in self._sizes().items():
            if g == group:
                return slice(start, start + n)
            start += n
        raise KeyError(group)

    @property
    def size(self) -> int:
        """p, the number of parameters (3 + (a + 1) m with the default groups)."""
        return sum(self._sizes().values())

    def shift(self, c: int) -> slice:
        """Where cable ``c``'s eyelet shift sits in theta.

        Parameters
        ----------
        c : int
            The cable's index.

        Returns
        -------
        slice
            The (a,) entries of theta holding its shift, m (empty without ``eyelets``).
        """
        a = len(AXES[self.axes]) if "eyelets" in self.groups else 0
        start = self.block("eyelets").start
        return slice(start + a * c, start + a * (c + 1))

    @property
    def slack(self) -> slice:
        """The entries of theta holding the cables' slack, m."""
        return self.block("slack")

    @property
    def names(self) -> list[str]:
        """One name per parameter, e.g. ``via_shift_y_m[top]``."""
        out = {
            "softness": ["log_softness"],
            "gradient": ["gradient_y", "gradient_z"],
            "eyelets": [f"via_shift_{'xyz'[i]}_m[{n}]" for n in self.cable_names for i in AXES[self.axes]],
            "slack": [f"slack_m[{self.cable_names[c]}]" for c in self.slack_indices],
            "density": ["density_factor"],
        }
        return [n for g in self.groups for n in out[g]]

    @property
    def units(self) -> list[str]:
        """The unit of each parameter (``"1"`` or ``"m"``)."""
        unit = {"softness": "1", "gradient": "1", "eyelets": "m", "slack": "m", "density": "1"}
        return [unit[g] for g in GROUPS for _ in range(self.block(g).stop - self.block(g).start)]

    def pack(self, softness=1.0, gradient=(0.0, 0.0), via_shift_m=None, slack_m=None, density=1.0) -> np.ndarray:
        """theta (p,) from softness s > 0, gradient (g_y, g_z), shifts (m, 3) m in frame W,
        slack (m,) m and the density factor. A shift along an axis the layout does not hold
        must be zero; the values of groups it does not fit are left out.

        Parameters
        ----------
        softness : float
            s = E_as-built / E (> 0).
        gradient : array_like, shape (2,)
            Stiffness gradient (g_y, g_z), dimensionless.
        via_shift_m : array_like, shape (m, 3), optional
            Eyelet shift of each cable in frame W, m; default none.
        slack_m : array_like, shape (m,), optional
            Slack of each cable, m (those without one are left out); default none.
        density : float
            theta_rho, the factor on the density (> 0).

        Returns
        -------
        ndarray, shape (p,)
            theta (ParameterError for a shift along an axis not held).
        """
        m, axes = self.n_cables, AXES[self.axes]
        shift = np.zeros((m, 3)) if via_shift_m is None else np.asarray(via_shift_m, float).reshape(m, 3)
        dropped = [i for i in range(3) if i not in axes]
        if "eyelets" in self.groups and np.any(shift[:, dropped]):
            raise ParameterError(f"eyelet shifts along x need axes='xyz', got {shift.tolist()}")
        slack = np.zeros(m) if slack_m is None else np.asarray(slack_m, float).reshape(m)
        parts = {
            "softness": [np.log(softness)],
            "gradient": np.asarray(gradient, float).reshape(2),
            "eyelets": shift[:, axes].ravel(),
            "slack": slack[list(self.slack_indices)],
            "density": [float(density)],
        }
        return np.concatenate([np.asarray(parts[g], float) for g in self.groups])

    def unpack(self, theta) -> dict:
        """The parameters of theta by name.

        Parameters
        ----------
        theta : array_like, shape (p,)
            The parameters (module docstring).

        Returns
        -------
        dict
            ``softness`` (float; 1 when not fitted), ``gradient`` (2,) or None when not
            fitted, ``via_shift_m`` (m, 3) m in frame W (zero when not fitted), ``slack_m``
            (m,) m (zero for a cable without slack) or None when not fitted, and
            ``density`` (the factor; 1 when not fitted). ParameterError for a theta of
            another size.
        """
        theta = np.asarray(theta, float)
        if theta.shape != (self.size,):
            raise ParameterError(f"expected {self.size} parameters ({', '.join(self.names)}), got shape {theta.shape}")
        shift = np.zeros((self.n_cables, 3))
        if "eyelets" in self.groups:
            shift[:, AXES[self.axes]] = theta[self.block("eyelets")].reshape(self.n_cables, -1)
        slack = None
        if "slack" in self.groups:
            slack = np.zeros(self.n_cables)
            slack[list(self.slack_indices)] = theta[self.slack]
        return {
            "softness": float(np.exp(theta[0])) if "softness" in self.groups else 1.0,
            "gradient": theta[self.block("gradient")].copy() if "gradient" in self.groups else None,
            "via_shift_m": shift,
            "slack_m": slack,
            "density": float(theta[self.block("density")][0]) if "density" in self.groups else 1.0,
        }
