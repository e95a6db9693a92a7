"""The arm's body in scikit-fem: the same tet mesh and neo-Hookean law, assembled by another FEM.

What a user would pick instead of our FEM for the material alone (torch-fem, the first
candidate, does not fit the pinned environment: docs/results-peers.md). :class:`SkfemArm`
builds, from an :class:`lab.fem.model.ArmFEM`: ``MeshTet`` on our nodes and tets with a
vector P1 basis; our compressible neo-Hookean law with our per-tet mu, lam as scikit-fem
forms (residual and tangent; P1 gradients are constant per tet, so the one-point rule is
exact and the body force integrates to our lumped gravity); the base nodes (x at its
minimum, within ``clamp_tol_m``) clamped; an optional point load on one node
(:func:`tip_load_node`). The two FEMs assemble the same discrete energy: differences are
rounding and the solvers' tolerances only. The cables are not modelled (scikit-fem has no
one-sided cable), so only slack-cable states compare. ``skfem`` is imported when an arm is
built. The forms in full: docs/design/peers.md.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from lab.errors import InputError, LabRuntimeError
from lab.fem.model import ArmFEM


def _skfem():
    try:
        import skfem
        import skfem.helpers
    except ImportError as e:  # a pinned dependency (environment.txt)
        raise LabRuntimeError("lab.peers.skfem_arm needs the 'scikit-fem' package (pinned in environment.txt)") from e
    return skfem


def tip_load_node(fem: ArmFEM) -> int:
    """The node that carries a tip load: the tip marker's node of largest barycentric weight."""
    return int(fem.tip_nodes[np.argmax(fem.tip_weights)])


def lab_loaded_arm(fem: ArmFEM, load_n: float, direction=(0.0, 0.0, -1.0), cable_slack_m: float = 0.01) -> ArmFEM:
    """Our arm on ``fem``'s mesh with slack cables and a point load on :func:`tip_load_node`.

    The load is added to the external load vector (gravity's, ``f_gravity_W``): the wrapper
    that gives our energy a tip load without changing lab.fem. Solve it with
    ``solve_static(arm, zeros(m))``.

    Parameters
    ----------
    fem : ArmFEM
        The arm whose description and mesh are used.
    load_n : float
        The point load (N).
    direction : array_like
        Its direction (3,), frame W; normalised here.
    cable_slack_m : float
        Slack of every cable (m), so that the cables carry nothing at motors 0.

    Returns
    -------
    ArmFEM
        A new arm with the load in ``f_gravity_W``.
    """
    arm = ArmFEM(fem.robot, fem.mesh, cable_slack_m=[cable_slack_m] * len(fem.cables))
    arm.f_gravity_W = arm.f_gravity_W.copy()
    arm.f_gravity_W[tip_load_node(fem)] += load_n * _unit(direction)
    return arm


def lab_tip_load_gradient(arm: ArmFEM, q: np.ndarray, direction=(0.0, 0.0, -1.0)) -> np.ndarray:
    """The tip's sensitivity d p_tip / d F to the tip load, with our exact Hessian.

    The equilibrium dE/dq (q, F) = 0 with dE/dq = grad E_el - f_ext(F) gives H dq/dF = df/dF,
    one solve (our ``dx/du`` machinery with the load as parameter).

    Parameters
    ----------
    arm : ArmFEM
        An arm from :func:`lab_loaded_arm`.
    q : numpy.ndarray
        Its equilibrium: the free coordinates (n_free,), m.
    direction : array_like
        The load's direction (3,), frame W; normalised here.

    Returns
    -------
    numpy.ndarray
        d p_tip / d F (3,), m/N, frame W.
    """
    from lab.fem.solve.linsolve import factorize

    f_dir = np.zeros((arm.mesh.n_nodes, 3))
    f_dir[tip_load_node(arm)] = _unit(direction)
    dq_dF = factorize(arm.hessian(q, np.zeros(len(arm.cables)))).solve(f_dir.ravel()[arm.free_dofs])
    return arm.tip_matrix() @ dq_dF


@dataclass
class SkfemSolution:
    """Equilibrium of :meth:`SkfemArm.solve`: node positions ``x_W`` (N, 3) m, tip marker
    ``p_tip_W`` (3,) m, the displacements in scikit-fem's dof order ``u_dofs`` (basis.N,) m,
    the point load ``load_n`` (N), Newton ``iterations`` and wall ``time_s`` (s)."""

    x_W: np.ndarray
    p_tip_W: np.ndarray
    u_dofs: np.ndarray
    load_n: float
    iterations: int
    time_s: float


def _unit(direction) -> np.ndarray:
    d = np.asarray(direction, dtype=float)
    if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) == 0:
        raise InputError(f"load direction must be a nonzero finite 3-vector, got {direction!r}")
    return d / np.linalg.norm(d)


class SkfemArm:
    """The arm's body (no cables) in scikit-fem on ``fem``'s mesh, materials and gravity.

    Parameters
    ----------
    fem : ArmFEM
        Our FEM of the arm: mesh, per-element Lamé parameters, density and gravity.
    clamp_tol_m : float
        Nodes within this distance (m) of the smallest x are clamped.
    """

    def __init__(self, fem: ArmFEM, clamp_tol_m: float = 1e-9):
        skfem = _skfem()
        h = skfem.helpers
        self.fem = fem
        X = fem.mesh.X_W
        self.mesh = skfem.MeshTet(np.ascontiguousarray(X.T), np.ascontiguousarray(fem.mesh.tets.T))
        self.basis = skfem.Basis(self.mesh, skfem.ElementVector(skfem.ElementTetP1()), intorder=1)
        nqp = self.basis.X.shape[1]
        self._mu = np.repeat(fem.elastic.mu[:, None], nqp, axis=1)  # (M, quadrature points)
        self._lam = np.repeat(fem.elastic.lam[:, None], nqp, axis=1)
        self._rho_g = fem.robot.density_kg_m3 * np.asarray(fem.robot.gravity_m_s2, float)
        dofs = self.basis.nodal_dofs  # (3, N): dof of axis i at node n
        self._dof = dofs.T  # (N, 3)
        clamped = X[:, 0] <= X[:, 0].min() + clamp_tol_m
        self.free = np.sort(dofs[:, ~clamped].ravel())
        self.X_flat = np.zeros(self.basis.N)
        self.X_flat[self._dof] = X  # rest positions in dof order

        def kin(w):
            F = h.grad(w["disp"]) + h.identity(w["disp"])
            J = h.det(F)
            return F, J, h.inv(F), np.log(np.maximum(J, 1e-300)), w["mu"], w["lam"]

        @skfem.Functional
        def energy(w):
            F, J, _, lnJ, mu, lam = kin(w)
            psi = 0.5 * mu * (h.ddot(F, F) - 3) - mu * lnJ + 0.5 * lam * lnJ**2
            return np.where(J > 0, psi, np.inf) - h.dot(w["rho_g"], w["disp"] + w.x)

        @skfem.LinearForm
        def residual(v, w):
            F, _, Fi, lnJ, mu, lam = kin(w)
            P = mu * F - (mu - lam * lnJ) * h.transpose(Fi)
            return h.ddot(P, h.grad(v)) - h.dot(w["rho_g"], v)

        @skfem.BilinearForm
        def tangent(du, v, w):
            F, _, Fi, lnJ, mu, lam = kin(w)
            dF, dV = h.grad(du), h.grad(v)
            A, B = h.mul(Fi, dF), h.mul(Fi, dV)
            return mu * h.ddot(dF, dV) + lam * h.trace(A) * h.trace(B) + (mu - lam * lnJ) * h.ddot(A, h.transpose(B))

        self._forms = (energy, residual, tangent)

    def _fields(self, u_flat):
        rho_g = np.broadcast_to(self._rho_g[:, None, None], (3,) + self._mu.shape)
        return {"disp": self.basis.interpolate(u_flat), "mu": self._mu, "lam": self._lam, "rho_g": rho_g}

    def energy(self, x_W: np.ndarray) -> float:
        """Elastic energy minus gravity's work (no point load; clamped nodes taken as given).

        Parameters
        ----------
        x_W : numpy.ndarray
            Node positions (N, 3), m, frame W.

        Returns
        -------
        float
            The energy (J); +inf if a tet is inverted.
        """
        u = np.zeros(self.basis.N)
        u[self._dof] = np.asarray(x_W, float) - self.fem.X_W
        return self._energy(u)

    def _energy(self, u_flat):
        return float(self._forms[0].assemble(self.basis, **self._fields(u_flat)))

    def _load(self, load_n, direction):
        f = np.zeros(self.basis.N)
        f[self._dof[tip_load_node(self.fem)]] = load_n * _unit(direction)
        return f

    def solve(
        self, load_n: float = 0.0, direction=(0.0, 0.0, -1.0), *, tol_step_m: float = 1e-10, max_iter: int = 50
    ) -> SkfemSolution:
        """Static equilibrium under gravity and a point load on :func:`tip_load_node`.

        Newton from rest with scikit-fem's assembled residual and tangent (SciPy's sparse LU
        on the free dofs) and a backtracking line search on the energy (an inverted tet has
        infinite energy); no safeguard against an indefinite tangent (ours has one), none was
        needed up to 50 mN.

        Parameters
        ----------
        load_n : float
            The point load (N).
        direction : array_like
            Its direction (3,), frame W; normalised here.
        tol_step_m : float
            Converged when no dof moves more than this (m).
        max_iter : int
            Most Newton iterations.

        Returns
        -------
        SkfemSolution
            Node positions, tip, displacements, iterations and wall time.

        Raises
        ------
        LabRuntimeError
            When the line search fails or Newton does not converge in ``max_iter``.
        """
        t0 = time.perf_counter()
        _, residual, tangent = self._forms
        f = self._load(load_n, direction)
        u = np.zeros(self.basis.N)
        I = self.free
        E = self._energy(u) - f @ u
        for it in range(1, max_iter + 1):
            w = self._fields(u)
            r = (residual.assemble(self.basis, **w) - f)[I]
            K = tangent.assemble(self.basis, **w)[I][:, I]
            lu = spla.splu(sp.csc_matrix(K))
            d = -lu.solve(r)
            step = float(np.abs(d).max())
            if step <= tol_step_m:  # Newton is quadratic here: take the step, no line search
                u[I] += d
                x = (self.X_flat + u)[self._dof]
                return SkfemSolution(x, self.fem.tip(x), u, load_n, it, time.perf_counter() - t0)
            alpha = 1.0
            for _ in range(40):
                u_try = u.copy()
                u_try[I] += alpha * d
                E_try = self._energy(u_try) - f @ u_try
                if E_try <= E + 1e-4 * alpha * (r @ d) + 1e-14 * abs(E):
                    break
                alpha *= 0.5
            else:
                raise LabRuntimeError(f"scikit-fem Newton: line search failed at iteration {it}")
            u, E = u_try, E_try
        raise LabRuntimeError(f"scikit-fem Newton did not converge in {max_iter} iterations (step {step:.2g} m)")

    def tip_load_gradient(self, sol: SkfemSolution, direction=(0.0, 0.0, -1.0)) -> np.ndarray:
        """The tip's sensitivity d p_tip / d F to the tip load, by the adjoint method.

        For each tip coordinate, K lam = dp_tip/du (the marker's barycentric weights; K
        symmetric), then dp_tip/dF = lam . df/dF, with the tangent assembled and factorised
        at the equilibrium (as our sensitivity does with our Hessian).

        Parameters
        ----------
        sol : SkfemSolution
            An equilibrium from :meth:`solve`.
        direction : array_like
            The load's direction (3,), frame W; normalised here.

        Returns
        -------
        numpy.ndarray
            d p_tip / d F (3,), m/N, frame W.
        """
        K = self._forms[2].assemble(self.basis, **self._fields(sol.u_dofs))[self.free][:, self.free]
        S = np.zeros((3, self.basis.N))
        for n, wgt in zip(self.fem.tip_nodes, self.fem.tip_weights):
            S[:, self._dof[n]] += wgt * np.eye(3)
        lam = spla.splu(sp.csc_matrix(K)).solve(np.ascontiguousarray(S[:, self.free].T))  # (n_free, 3)
        return lam.T @ self._load(1.0, direction)[self.free]
