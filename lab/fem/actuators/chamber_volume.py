"""Volume-controlled chambers: cavities filled by a syringe or pump with a given fluid volume.

The input u_c (m^3) is the fluid volume injected into chamber c since rest. The chamber is
full of fluid of bulk modulus K_c (Pa; water's 2.2e9 by default), so it holds the pressure

    p_c = K_c (V0_c + u_c - V_c(x)) / V0_c

with the cavity volume V_c(x) of :mod:`lab.fem.actuators.chamber` (the divergence theorem
over its closed surface), and the fluid's energy is

    E = sum_c K_c / (2 V0_c) (V_c(x) - V0_c - u_c)^2,

a penalty form of the constraint V_c = V0_c + u_c whose multiplier is the pressure (exact
as K -> inf, and physically the fluid's own compressibility). Gradient -p dV/dq; Hessian
(K/V0) dV/dq dV/dq^T - p d2V/dq2; d2E/dq du_c = -(K_c/V0_c) dV_c/dq. The rank-one term
couples every dof of the cavity's wall, so it is not assembled: :meth:`gradient` returns a
:class:`~lab.fem.actuators.base.Condensation` (A = dV/dq, the linear law tau = (K/V0) e,
``in_hessian=False``) that the statics add exactly by Woodbury; :meth:`hessian_blocks`
carries only the follower term -p d2V/dq2, :meth:`hessian_product` both.
"""

from __future__ import annotations

import numpy as np

from lab.description.chambers import WATER_BULK_MODULUS_PA
from lab.errors import InputError
from lab.fem.actuators.base import Actuator, Condensation, register_actuator
from lab.fem.actuators.chamber import PressureChamberActuator, description_walls, oriented_walls
from lab.fem.actuators.chamber_surfaces import cavity_volume


def _names(names, n: int) -> list[str]:
    names = [str(i) for i in range(n)] if names is None else [str(s) for s in names]
    if len(names) != n:
        raise InputError(f"chambers_volume: {len(names)} names for {n} chambers")
    return names


@register_actuator("chambers_volume")
class VolumeChamberActuator(Actuator):
    """Cavities in the body filled with given fluid volumes (m^3 injected since rest, one per chamber).

    Parameters
    ----------
    surfaces : list of ndarray of int, shape (T_c, 3)
        Each chamber's closed surface, wound with normals into the cavity.
    X_W : ndarray, shape (N, 3)
        Rest node positions, m.
    free : FreeCoordinates
        The body's free coordinates.
    volume_max_m3 : array_like, shape (n,) or scalar
        The largest injected volume of each chamber, m^3.
    volume_min_m3 : array_like, shape (n,) or scalar
        The smallest (negative: fluid withdrawn), m^3; default 0.
    fluid_bulk_modulus_pa : array_like, shape (n,) or scalar
        The fluid's bulk modulus K per chamber, Pa (> 0); default water's 2.2e9.
    names : sequence of str, optional
        The chambers' names; default ``"0"``, ``"1"``, ...
    """

    input_unit = "m^3"
    condenses = True

    def __init__(
        self,
        surfaces,
        X_W,
        free,
        volume_max_m3,
        volume_min_m3=0.0,
        fluid_bulk_modulus_pa=WATER_BULK_MODULUS_PA,
        names=None,
    ):
        n = len(surfaces)
        self.names = tuple(_names(names, n))
        self.input_names = tuple(f"volume_m3[{s}]" for s in self.names)
        V0 = np.array([cavity_volume(X_W, np.asarray(s, dtype=np.int64)) for s in surfaces])
        if np.any(V0 <= 0):
            raise InputError(f"chambers_volume: rest volumes {V0.tolist()} m^3 must be > 0")
        # The geometry (V, dV/dq, the follower blocks at a pressure) is the pressure chambers'.
        self.geometry = PressureChamberActuator(surfaces, X_W, free, 1.0, self.names)
        self.surfaces, self.free, self.V0_m3 = self.geometry.surfaces, free, self.geometry.V0_m3

        def per_chamber(value, what):
            v = np.broadcast_to(np.asarray(value, float), (n,)).copy()
            if not np.all(np.isfinite(v)):
                raise InputError(f"chambers_volume: {what} {v.tolist()} must be finite")
            return v

        self.volume_max_m3 = per_chamber(volume_max_m3, "volume_max_m3")
        self.volume_min_m3 = per_chamber(volume_min_m3, "volume_min_m3")
        if np.any(self.volume_max_m3 <= self.volume_min_m3) or np.any(self.volume_max_m3 <= 0):
            raise InputError(
                f"chambers_volume: volume_max_m3 {self.volume_max_m3.tolist()} m^3 must be > 0 and above "
                f"volume_min_m3 {self.volume_min_m3.tolist()} m^3"
            )
        self.bulk_modulus_pa = per_chamber(fluid_bulk_modulus_pa, "fluid_bulk_modulus_pa")
        if np.any(self.bulk_modulus_pa <= 0):
            raise InputError(f"chambers_volume: fluid_bulk_modulus_pa {self.bulk_modulus_pa.tolist()} Pa must be > 0")
        #: K / V0 per chamber, Pa/m^3: the law's stiffness (J/m^6).
        self.stiffness = self.bulk_modulus_pa / self.V0_m3

    @classmethod
    def build(
        cls,
        robot,
        body,
        free,
        *,
        surfaces=None,
        volume_max_m3=None,
        volume_min_m3=0.0,
        fluid_bulk_modulus_pa=WATER_BULK_MODULUS_PA,
        names=None,
        chambers=None,
    ) -> VolumeChamberActuator:
        """Volume-controlled chambers on cavities of ``body``'s mesh, surfaces oriented from the mesh.

        Parameters
        ----------
        robot : RobotDescription
            The description: its volume-controlled ``chambers`` unless ``surfaces`` is given.
        body : Body
            The body whose mesh holds the cavities (its ``groups`` name their walls).
        free : FreeCoordinates
            Its free coordinates.
        surfaces : list of ndarray of int, shape (T_c, 3), optional
            Each chamber's closed surface (boundary faces of the mesh, any winding; e.g.
            :func:`~lab.fem.actuators.chamber_surfaces.cavity_surfaces`).
        volume_max_m3 : array_like, shape (n,) or scalar, optional
            The largest injected volume of each chamber, m^3 (with ``surfaces``).
        volume_min_m3 : array_like, shape (n,) or scalar
            The smallest, m^3 (default 0; negative withdraws fluid).
        fluid_bulk_modulus_pa : array_like, shape (n,) or scalar
            The fluid's bulk modulus per chamber, Pa (default water's 2.2e9).
        names : sequence of str, optional
            The chambers' names for :attr:`input_names`; default their indices.
        chambers : sequence of int, optional
            Which of ``robot.chambers`` (indices; default every volume-controlled one).

        Returns
        -------
        VolumeChamberActuator
            The chambers, with their rest volumes.
        """
        if surfaces is None:
            picked, walls, low, high = description_walls(robot, body, chambers, "volume")
            bulk = [c.fluid_bulk_modulus_pa or WATER_BULK_MODULUS_PA for c in picked]
            return cls(walls, body.mesh.X_W, free, high, low, bulk, [c.name for c in picked])
        oriented, names = oriented_walls(body, surfaces, names, cls.kind)
        return cls(oriented, body.mesh.X_W, free, volume_max_m3, volume_min_m3, fluid_bulk_modulus_pa, names)

    def input_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """[volume_min_m3, volume_max_m3] per chamber.

        Returns
        -------
        low, high : ndarray, shape (n,)
            Bounds in m^3.
        """
        return self.volume_min_m3.copy(), self.volume_max_m3.copy()

    def check_input(self, u) -> np.ndarray:
        """``u`` as floats; refused (InputError naming the chamber) if NaN, outside the
        bounds, or so negative that it would collapse a cavity (u_c <= -V0_c).

        Parameters
        ----------
        u : array_like, shape (n,)
            Injected volumes, m^3.

        Returns
        -------
        ndarray, shape (n,)
            The inputs.
        """
        v = np.asarray(u, float).reshape(self.n_inputs)
        collapse = np.isfinite(v) & (v <= -self.V0_m3)
        if np.any(collapse):
            i = int(np.flatnonzero(collapse)[0])
            raise InputError(
                f"chambers_volume: chamber {self.names[i]!r} would collapse: {self.input_names[i]} = {v[i]} m^3 "
                f"withdraws at least its rest volume {self.V0_m3[i]} m^3"
            )
        return super().check_input(v)

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
        return self.geometry.volumes(x_W)

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
        return self.geometry.volume_gradients(x_W)

    def _stretch(self, x_W, u) -> np.ndarray:
        """e = V - V0 - u (n,), m^3: the fluid's compression (negative: it is squeezed)."""
        return self.volumes(x_W) - self.V0_m3 - np.asarray(u, float)

    def pressures(self, x_W, u) -> np.ndarray:
        """The gauge pressure each chamber holds, K (V0 + u - V) / V0.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Injected volumes, m^3.

        Returns
        -------
        ndarray, shape (n,)
            Pressures, Pa.
        """
        return -self.stiffness * self._stretch(x_W, u)

    def law(self, e):
        """The fluid's linear law in its compression e = V - V0 - u.

        Parameters
        ----------
        e : ndarray, shape (n,)
            Stretches, m^3.

        Returns
        -------
        tuple of ndarray, shape (n,)
            Energy (J), force tau = (K/V0) e = -p (Pa = J/m^3), stiffness K/V0 (J/m^6).
        """
        e = np.asarray(e, float)
        return 0.5 * self.stiffness * e * e, self.stiffness * e, self.stiffness.copy()

    def energy(self, x_W, u) -> float:
        """The fluid's energy, sum_c K_c / (2 V0_c) (V_c - V0_c - u_c)^2.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Injected volumes, m^3.

        Returns
        -------
        float
            Energy, J.
        """
        return float(np.sum(self.law(self._stretch(x_W, u))[0]))

    def gradient(self, x_W, u):
        """Gradient -sum_c p_c dV_c/dq, and the condensation that carries the rank-one term.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Injected volumes, m^3.

        Returns
        -------
        g : ndarray, shape (n_free,)
            dE/dq, N.
        condensation : Condensation
            A = dV/dq (n_free, n) m^2, stretch V - V0 - u (n,) m^3, the law :meth:`law`,
            gain -1, ``in_hessian=False`` (the statics add A (K/V0) A^T by Woodbury).
        """
        A = self.volume_gradients(x_W)
        e = self._stretch(x_W, u)
        g = A @ (self.stiffness * e)
        scale = 1e-9 * float(self.V0_m3.min())
        return g, Condensation(A, e, self.law, scale, slice(0, self.n_inputs), -1.0, in_hessian=False)

    def block_dofs(self) -> list[np.ndarray]:
        """One 9x9 block per wall triangle (the follower term; the rank-one term is not assembled).

        Returns
        -------
        list of ndarray, shape (T, 9)
            Mesh dofs of every chamber triangle, one row each.
        """
        return self.geometry.block_dofs()

    def hessian_blocks(self, x_W, u) -> list[np.ndarray]:
        """-p_c d2V_c/dx2 on each triangle, ravelled: the Hessian WITHOUT its rank-one
        term (K/V0) dV dV^T, which the condensation carries.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Injected volumes, m^3.

        Returns
        -------
        list of ndarray, shape (81 T,)
            The (T, 9, 9) blocks, ravelled, N/m.
        """
        return self.geometry.hessian_blocks(x_W, self.pressures(x_W, u))

    def hessian_product(self, x_W, u):
        """Exact Hessian products: the follower term and the rank-one term A (K/V0) A^T.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Injected volumes, m^3.

        Returns
        -------
        callable
            ``(acc, v, dx_W) -> acc + d2E/dq2 v`` for ``v`` (n_free,) m and the same
            displacement on the nodes ``dx_W`` (N, 3) m; ``acc`` (n_free,) N.
        """
        follower = self.geometry.hessian_product(x_W, self.pressures(x_W, u))
        A = self.volume_gradients(x_W)
        return lambda acc, v, dx_W: follower(acc, v, dx_W) + A @ (self.stiffness * (A.T @ v))

    def mixed_derivative(self, x_W, u) -> np.ndarray:
        """d2E/dq du_c = -(K_c/V0_c) dV_c/dq.

        Parameters
        ----------
        x_W : ndarray, shape (N, 3)
            Node positions, m.
        u : ndarray, shape (n,)
            Injected volumes, m^3.

        Returns
        -------
        ndarray, shape (n_free, n)
            d2E/dq du, N/m^3.
        """
        return -self.volume_gradients(x_W) * self.stiffness[None, :]
