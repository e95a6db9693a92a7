"""The set of allowed motor commands and exact projections / small QPs over it.

A robot may only be sent commands ``u`` (m,) rad in the polyhedron
``C = {u : lo <= u <= hi, A u <= b}`` (``lo = 0``, ``hi = u_max``, one row of ``A`` per
safety limit of the robot description). Inverse kinematics keeps every iterate in ``C``
with :meth:`CommandSet.project` (the Euclidean projection) and :meth:`CommandSet.solve_qp`
(the bounded Levenberg-Marquardt step), both solved exactly by a primal active-set method
after cheap exact shortcuts (docs/design/ik.md: the allowed commands).
"""

from __future__ import annotations

import numpy as np

from lab.description import RobotDescription
from lab.errors import InputError, LabRuntimeError


class CommandSet:
    """Polyhedron ``{lo <= u <= hi, A u <= b}`` of allowed commands (rad).

    The lower corner ``lo`` must be feasible (it is the start of the active-set method);
    ValueError otherwise.

    Parameters
    ----------
    lo, hi : array_like
        Lower and upper bounds (m,), rad, finite, ``lo < hi``.
    A : array_like, optional
        Rows (k, m) of the linear limits (k may be 0); default none.
    b : array_like, optional
        Their right-hand sides (k,), rad.
    tol : float
        Slack used by :meth:`contains` and the active-set tests, relative to the largest
        motor range (so ``self.tol`` is in rad).
    """

    def __init__(self, lo, hi, A=None, b=None, tol: float = 1e-12):
        self.lo, self.hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
        m = len(self.lo)
        if self.lo.shape != (m,) or self.hi.shape != (m,) or m == 0:
            raise InputError(f"lo and hi must be vectors of the same length, got {self.lo.shape}, {self.hi.shape}")
        if not (np.all(np.isfinite(self.lo)) and np.all(np.isfinite(self.hi)) and np.all(self.lo < self.hi)):
            raise InputError(f"need finite bounds with lo < hi, got lo={self.lo}, hi={self.hi}")
        self.A = np.zeros((0, m)) if A is None else np.atleast_2d(np.array(A, dtype=float))
        self.b = np.zeros(0) if b is None else np.atleast_1d(np.array(b, dtype=float))
        if self.A.shape != (len(self.b), m):
            raise InputError(f"A must be (k, {m}) and b (k,), got {self.A.shape} and {self.b.shape}")
        self.scale = float(np.max(self.hi - self.lo))
        self.tol = float(tol) * self.scale
        if np.any(self.A @ self.lo > self.b + self.tol):
            raise InputError("the lower corner lo violates A u <= b: this command set needs a feasible lo")
        eye = np.eye(m)
        self.G = np.vstack([-eye, eye, self.A])  # G x <= h
        self.h = np.concatenate([-self.lo, self.hi, self.b])

    @classmethod
    def from_robot(cls, robot: RobotDescription) -> CommandSet:
        """The robot's input ranges ``[u_lower, u_upper]`` (angles in rad, tensions in N)
        intersected with its linear safety limits (which concern angle cables).

        Parameters
        ----------
        robot : RobotDescription
            Gives the number of inputs m, each input's range and the safety limits.

        Returns
        -------
        CommandSet
            The robot's allowed commands.
        """
        m = robot.n_inputs
        A = np.zeros((len(robot.safety_limits), m))
        b = np.zeros(len(robot.safety_limits))
        for i, lim in enumerate(robot.safety_limits):
            A[i, list(lim.cables)] = 1.0
            b[i] = lim.max_sum_over_u_max * robot.u_max_rad
        return cls(np.asarray(robot.u_lower, float), np.asarray(robot.u_upper, float), A, b)

    @property
    def n(self) -> int:
        """Number of motors m."""
        return len(self.lo)

    def contains(self, u, tol: float | None = None) -> bool:
        """Whether ``u`` lies in the set.

        Parameters
        ----------
        u : array_like
            A command (m,), rad.
        tol : float, optional
            Slack (rad); default the set's ``tol``.

        Returns
        -------
        bool
            True when every limit holds up to ``tol`` (False for NaN or inf).
        """
        tol = self.tol if tol is None else tol
        # NaN or inf in u gives NaN or inf in G u (G bounds every motor from both sides), and
        # the comparison is then False: no separate finiteness test (this runs per IK step).
        return bool((self.G @ np.asarray(u, dtype=float) <= self.h + tol).all())

    def project(self, v, x0=None) -> np.ndarray:
        """Euclidean projection of ``v`` onto the set (exact, see the module docstring).

        Parameters
        ----------
        v : array_like
            A finite command (m,), rad.
        x0 : array_like, optional
            A feasible starting point (m,), rad (e.g. the previous iterate).

        Returns
        -------
        numpy.ndarray
            The nearest allowed command (m,), rad.
        """
        v = np.asarray(v, dtype=float)
        if v.shape != (self.n,) or not np.isfinite(v).all():
            raise InputError(f"cannot project {v!r}: need a finite vector of {self.n} angles")
        if self.contains(v, 0.0):
            return v.copy()
        c = np.clip(v, self.lo, self.hi)
        if (self.A @ c <= self.b).all():
            return c
        return self.solve_qp(np.eye(self.n), -v, x0)

    def solve_qp(self, H, c, x0=None, max_iter: int | None = None) -> np.ndarray:
        """``argmin_{x in C} 1/2 x^T H x + c^T x``, by a primal active-set method, exact to rounding.

        Parameters
        ----------
        H : array_like
            Symmetric positive-definite (m, m).
        c : array_like
            Linear term (m,).
        x0 : array_like, optional
            A feasible starting point (m,), rad; default ``lo``.
        max_iter : int, optional
            Most iterations; default ``20 (k + 3m)`` (k limit rows, m motors).

        Returns
        -------
        numpy.ndarray
            The minimiser (m,), rad.
        """
        H, c = np.asarray(H, dtype=float), np.asarray(c, dtype=float)
        m = self.n
        x = self.lo.copy() if x0 is None else np.array(x0, dtype=float)
        if not self.contains(x, 1e3 * self.tol):
            raise InputError("solve_qp needs a feasible starting point x0")
        x = np.clip(x, self.lo, self.hi)
        work = self._independent(np.flatnonzero(self.G @ x >= self.h - self.tol))
        max_iter = max_iter or 20 * (len(self.h) + m)
        # After an unblocked full step x is the working set's minimiser: its p is zero in
        # exact arithmetic, but in rounding it is ~eps cond(H) |x|, which on an ill-conditioned
        # H (a damped rank-3 J^T J of six motors) can exceed any fixed threshold and made the
        # method repeat the same tiny step forever. So the flag, not |p|, says "at minimiser".
        at_minimiser = False
        for _ in range(max_iter):
            g = H @ x + c
            Gw = self.G[work]
            n_w = len(work)
            K = np.zeros((m + n_w, m + n_w))
            K[:m, :m], K[:m, m:], K[m:, :m] = H, Gw.T, Gw
            sol = np.linalg.solve(K, np.concatenate([-g, np.zeros(n_w)]))
            p, lam = sol[:m], sol[m:]
            if at_minimiser or np.max(np.abs(p)) <= 1e-13 * (self.scale + np.max(np.abs(x))):
                if n_w == 0 or lam.min() >= -1e-13 * (1.0 + np.abs(g).max()):
                    return x
                work = np.delete(work, int(np.argmin(lam)))
                at_minimiser = False
                continue
            Gp = self.G @ p
            slack = self.h - self.G @ x
            blocking = np.flatnonzero(Gp > 0)
            blocking = blocking[~np.isin(blocking, work)]
            alpha, hit = 1.0, None
            if len(blocking):
                ratios = np.maximum(slack[blocking], 0.0) / Gp[blocking]
                j = int(np.argmin(ratios))
                if ratios[j] < 1.0:
                    alpha, hit = float(ratios[j]), int(blocking[j])
            x = x + alpha * p
            if hit is not None:
                work = np.append(work, hit)
            at_minimiser = hit is None
        raise LabRuntimeError(f"active-set QP did not terminate in {max_iter} iterations (degenerate problem?)")

    def _independent(self, rows: np.ndarray) -> np.ndarray:
        """A maximal subset of ``rows`` of G with linearly independent constraint normals."""
        keep: list[int] = []
        for r in rows:
            trial = self.G[keep + [int(r)]]
            if np.linalg.matrix_rank(trial, tol=1e-10) == len(keep) + 1:
                keep.append(int(r))
        return np.array(keep, dtype=int)
