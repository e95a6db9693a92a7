"""Pressure chambers: closed cavities in the body, each held at a given gauge pressure.

A cavity is a closed triangle surface of the body's mesh: boundary faces of the tet mesh,
each belonging to exactly one tet. Each face is wound so that its normal points away from
its tet, i.e. INTO the cavity (the winding :meth:`TetMesh.surface_triangles` gives every
boundary face); :func:`~lab.fem.actuators.chamber_surfaces.cavity_surfaces` finds them and
:class:`PressureChamberActuator` re-orients the surfaces it is given the same way, from the
mesh (:mod:`lab.fem.actuators.chamber_surfaces`).

With that winding the divergence theorem gives the cavity's volume as

    V(x) = -sum_tri det[x1, x2, x3] / 6

(exact for a closed surface, independent of the origin). A gauge pressure p (Pa) held
constant whatever the body does does the work p dV, so the chambers' energy is

    E = -sum_c p_c (V_c(x) - V_c(X)),

its gradient -p dV/dq, its Hessian -p d2V/dq2 (the follower-load term: one symmetric,
indefinite 9x9 block per triangle with zero diagonal 3x3 blocks) and d2E/dq dp_c = -dV_c/dq.
Linear in the inputs and smooth in q: no condensation.
"""

from __future__ import annotations

import numpy as np

from lab.errors import InputError
from lab.fem.actuators.base import Actuator, register_actuator
from lab.fem.actuators.chamber_surfaces import cavity_volume, oriented_surface


@register_actuator("chambers_pressure")
class PressureChamberActuator(Actuator):
    """Cavities in the body held at gauge pressures (Pa, one per chamber).

    Parameters
    ----------
    surfaces : list of ndarray of int, shape (T_c, 3)
        Each chamber's closed surface, wound with normals into the cavity.
    X_W : ndarray, shape (N, 3)
        Rest node positions, m.
    free : FreeCoordinates
        The body's free coordinates.
    pressure_max_pa : array_like, shape (n,) or scalar
        The largest gauge pressure of each chamber, Pa (> 0).
    names : sequence of str, optional
        The chambers' names; default ``"0"``, ``"1"``, ...
    pressure_min_pa : array_like, shape (n,) or scalar
        The smallest gauge pressure of each chamber, Pa (0; negative: vacuum allowed).
    """

    input_unit = "Pa"

    def __init__(self, surfaces, X_W, free, pressure_max_pa, names=None, pressure_min_pa=0.0):
        self.surfaces = [np.asarray(s, dtype=np.int64) for s in surfaces]
        self.free = free
        names = [str(i) for i in range(len(self.surfaces))] if names is None else list(names)
        if len(names) != len(self.surfaces):
            raise InputError(f"chambers_pressure: {len(names)} names for {len(self.surfaces)} chambers")
        self.names = tuple(names)
        self.input_names = tuple(f"pressure_pa[{n}]" for n in names)
        high = np.broadcast_to(np.asarray(pressure_max_pa, float), (len(self.surfaces),)).copy()
        if not np.all(np.isfinite(high)) or np.any(high <= 0):
            raise InputError(f"chambers_pressure: pressure_max_pa {high.tolist()} Pa must be finite and > 0")
        self.pressure_max_pa = high
        low = np.broadcast_to(np.asarray(pressure_min_pa, float), (len(self.surfaces),)).copy()
        if not np.all(np.isfinite(low)) or np.any(low < -101_325.0) or np.any(low >= high):
            raise InputError(
                f"chambers_pressure: pressure_min_pa {low.tolist()} Pa must be at least vacuum and below the maximum"
            )
        self.pressure_min_pa = low
        self.V0_m3 = self.volumes(X_W)
        if np.any(self.V0_m3 <= 0):
            raise InputError(f"chambers_pressure: rest volumes {self.V0_m3.tolist()} m^3 must be > 0")
        self._tri = np.concatenate(self.surfaces)
        self._chamber = np.repeat(np.arange(len(self.surfaces)), [len(s) for s in self.surfaces])
        dofs = (3 * self._tri[:, :, None] + np.arange(3)).reshape(-1, 9)
        self._free = free.dof_to_free[dofs]  # (T, 9), -1 where clamped

    @classmethod
    def build(
        cls, robot, body, free, *, surfaces=None, pressure_max_pa=None, names=None, chambers=None
    ) -> PressureChamberActuator:
        """Chambers on cavities of ``body``'s mesh: the description's, or the surfaces given.

        Parameters
        ----------
        robot : RobotDescription
            The description: its pressure-controlled ``chambers`` unless ``surfaces`` is given.
        body : Body
            The body whose mesh holds the cavities (its ``groups`` name their walls).
        free : FreeCoordinates
            Its free coordinates.
        surfaces : list of ndarray of int, shape (T_c, 3), optional
            Each chamber's closed surface (boundary faces of the mesh, any winding; e.g.
            :func:`cavity_surfaces`); each face is wound away from its tet, into the cavity.
        pressure_max_pa : array_like, shape (n,) or scalar, optional
            The largest gauge pressure of each chamber, Pa (with ``surfaces``).
        names : sequence of str, optional
            The chambers' names for :attr:`input_names`; default their indices.
        chambers : sequence of int, optional
            Which of ``robot.chambers`` (indices; default every pressure-controlled one).

        Returns
        -------
        PressureChamberActuator
            The chambers, with their rest volumes.
        """
        if surfaces is None:
            picked, walls, low, high = description_walls(robot, body, chambers, "pressure")
            return cls(walls, body.mesh.X_W, free, high, [c.name for c in picked], low)
        oriented, names = oriented_walls(body, surfaces, names, cls.kind)
        return cls(oriented, body.mesh.X_W, free, pressure_max_pa, names)

    def input_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """[pressure_min_pa, pressure_max_pa] Pa per chamber.

        Returns
        -------
        low, high : ndarray, shape (n,)
            Bounds in Pa.
        """
        return self.pressure_min_pa.copy(), self.pressure_max_pa.copy()

    def volumes(self, x_W) -> np.ndarray:
        """The cavities' volumes.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.

        Returns
        -------
        ndarray, shape (n,)
            Volumes, m^3.
        """
        return np.array([cavity_volume(x_W, s) for s in self.surfaces])

    def _to_free(self, per_tri: np.ndarray) -> np.ndarray:
        """Scatter (T, 9) per-triangle dof values to (n_free,)."""
        out = np.zeros(self.free.n_free)
        keep = self._free >= 0
        np.add.at(out, self._free[keep], per_tri[keep])
        return out

    def _dV(self, x_W) -> np.ndarray:
        """dV/dx of each triangle's node coordinates (T, 9), m^2."""
        a, b, c = (x_W[self._tri[:, k]] for k in range(3))
        return -np.concatenate([np.cross(b, c), np.cross(c, a), np.cross(a, b)], axis=1) / 6.0

    def volume_gradients(self, x_W) -> np.ndarray:
        """dV_c/dq of every chamber.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.

        Returns
        -------
        ndarray, shape (n_free, n)
            dV/dq, m^3 per m.
        """
        dV = self._dV(x_W)
        return np.stack(
            [self._to_free(np.where((self._chamber == c)[:, None], dV, 0.0)) for c in range(len(self.surfaces))], axis=1
        )

    def energy(self, x_W, u) -> float:
        """The pressures' work, -sum_c p_c (V_c - V0_c).

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Gauge pressures, Pa.

        Returns
        -------
        float
            Energy, J.
        """
        return -float(np.asarray(u, float) @ (self.volumes(x_W) - self.V0_m3))

    def gradient(self, x_W, u):
        """Gradient -sum_c p_c dV_c/dq.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Gauge pressures, Pa.

        Returns
        -------
        g : ndarray, shape (n_free,)
            dE/dq, N.
        condensation : None
            No condensation (linear in p, smooth in q).
        """
        p = np.asarray(u, float)[self._chamber][:, None]
        return self._to_free(-p * self._dV(x_W)), None

    def block_dofs(self) -> list[np.ndarray]:
        """One 9x9 block per triangle over its three nodes' dofs.

        Returns
        -------
        list of ndarray, shape (T, 9)
            Mesh dofs (ravelled x, y, z per node) of every chamber triangle, one row each.
        """
        return [(3 * self._tri[:, :, None] + np.arange(3)).reshape(-1, 9)]

    def _blocks(self, x_W, u) -> np.ndarray:
        """-p d2V/dx2 per triangle, (T, 9, 9) in N/m."""
        x = [x_W[self._tri[:, k]] for k in range(3)]
        p = np.asarray(u, float)[self._chamber]
        H = np.zeros((len(self._tri), 3, 3, 3, 3))
        # E_tri = p x0 . (x1 x x2) / 6, and for (i, j, k) cyclic d2/dx_i dx_j of
        # x_i . (x_j x x_k) is -[x_k]_x (its transpose, [x_k]_x, for j, i; zero for i = j).
        for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            S = _skew(x[k])
            H[:, i, :, j, :] = -S
            H[:, j, :, i, :] = S
        return (p[:, None, None] / 6.0) * H.reshape(-1, 9, 9)

    def hessian_blocks(self, x_W, u) -> list[np.ndarray]:
        """-p_c d2V_c/dx2 on each triangle, ravelled.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Gauge pressures, Pa.

        Returns
        -------
        list of ndarray, shape (81 T,)
            The (T, 9, 9) blocks over :meth:`block_dofs`, ravelled, N/m.
        """
        return [self._blocks(x_W, u).ravel()]

    def hessian_product(self, x_W, u):
        """The follower load turning with the walls: -p d(dV/dx) along a displacement.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Gauge pressures, Pa.

        Returns
        -------
        callable
            ``(acc, v, dx_W) -> acc + d2E/dq2 v`` for ``v`` (n_free,) m and the same
            displacement on the nodes ``dx_W`` (N, 3) m; ``acc`` (n_free,) N.
        """
        x = [x_W[self._tri[:, k]] for k in range(3)]
        p = np.asarray(u, float)[self._chamber][:, None] / 6.0

        def apply(acc, v, dx_W):
            d = [dx_W[self._tri[:, k]] for k in range(3)]
            turn = np.concatenate(
                [
                    np.cross(d[1], x[2]) + np.cross(x[1], d[2]),
                    np.cross(d[2], x[0]) + np.cross(x[2], d[0]),
                    np.cross(d[0], x[1]) + np.cross(x[0], d[1]),
                ],
                axis=1,
            )
            return acc + self._to_free(p * turn)

        return apply

    def mixed_derivative(self, x_W, u) -> np.ndarray:
        """How the pressures change the forces: d2E/dq dp_c = -dV_c/dq.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Gauge pressures, Pa.

        Returns
        -------
        ndarray, shape (n_free, n)
            d2E/dq dp, N/Pa (m^2).
        """
        return -self.volume_gradients(x_W)


def _skew(v: np.ndarray) -> np.ndarray:
    """[v]_x (..., 3, 3) with [v]_x w = v x w."""
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    return S - np.swapaxes(S, -1, -2)


def description_walls(robot, body, chambers, control: str):
    """The description's chambers of one control and their cavities' walls on ``body``.

    Parameters
    ----------
    robot : RobotDescription
        The description.
    body : Body
        The body whose mesh holds the cavities (its ``groups`` name their walls).
    chambers : sequence of int or None
        Indices into ``robot.chambers``; None: every chamber of this control.
    control : str
        ``"pressure"`` or ``"volume"``.

    Returns
    -------
    picked : list of Chamber
        The chambers.
    walls : list of ndarray of int, shape (T_c, 3)
        Each one's closed surface, wound into the cavity.
    low, high : ndarray, shape (n,)
        Their input bounds (Pa or m^3).
    """
    from lab.fem.bodies import chamber_surface

    picked = (
        [c for c in robot.chambers if c.control == control]
        if chambers is None
        else [robot.chambers[j] for j in chambers]
    )
    if not picked or any(c.control != control for c in picked):
        raise InputError(f"robot {robot.name!r}: chambers_{control} needs {control}-controlled chambers")
    walls = [chamber_surface(body, c.surface_group or c.name, c.name) for c in picked]
    low, high = np.array([c.bounds for c in picked]).T
    return picked, walls, low, high


def oriented_walls(body, surfaces, names, kind: str):
    """Given cavity surfaces as boundary faces of ``body``'s mesh, each wound into its cavity.

    Parameters
    ----------
    body : Body
        The body.
    surfaces : list of ndarray of int, shape (T_c, 3)
        The surfaces, any winding.
    names : sequence of str or None
        The chambers' names (default their indices).
    kind : str
        The actuator's name, for the error.

    Returns
    -------
    oriented : list of ndarray of int, shape (T_c, 3)
        The surfaces, wound away from their tets.
    names : list of str
        The names.
    """
    names = [str(i) for i in range(len(surfaces))] if names is None else [str(n) for n in names]
    if len(names) != len(surfaces):
        raise InputError(f"{kind}: {len(names)} names for {len(surfaces)} chambers")
    return [oriented_surface(body.mesh, s, n) for s, n in zip(surfaces, names)], names
