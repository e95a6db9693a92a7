"""A Kalman filter of the foam's relaxation: where the tip is going, before it gets there.

The state, the same for each of the three axes, is the ``K`` relaxation modes of
:class:`~lab.dynamics.relaxation.Relaxation` plus the equilibria of named poses (the capture's
``reset`` and ``rest`` poses, and the current ``target``). Between readings the modes follow
the equilibrium, which ramps linearly from one pose to the next while the motors turn
(:meth:`TipFilter.advance`); each reading (the mean of ``n`` frames, noise variance
``sigma^2 / n`` per axis) updates every state (:meth:`TipFilter.update`). The target's
equilibrium -- the settled tip the capture wants -- is therefore estimated, with its
uncertainty, from the first part of the transient, and the history of earlier samples
(the modes do not start from rest) is carried rather than waited out.

The three axes share dynamics, noise and covariance, so one covariance matrix (n, n) and a
mean (n, 3) describe all of them.
"""

from __future__ import annotations

import numpy as np

from lab.dynamics.relaxation import Relaxation


class TipFilter:
    """Kalman filter over modes + pose equilibria; state mean ``x`` (n, 3) m and covariance
    ``P`` (n, n) m^2 shared by the three axes, n = K modes + the poses.

    Parameters
    ----------
    relax : Relaxation
        The foam's relaxation (K modes: time constants, weights, noise).
    poses : tuple of str
        Names of the pose equilibria in the state.
    prior_sigma_m : float
        Prior std of a pose never seen (m per axis).
    process_noise_m2_per_s : float
        Random walk of the modes (model error, m^2/s per axis).
    noise_sigma_m : float, optional
        Motion-capture noise per frame and axis (m); default: the relaxation's.
    """

    def __init__(
        self,
        relax: Relaxation,
        poses=("reset", "rest", "target"),
        *,
        prior_sigma_m: float = 0.05,
        process_noise_m2_per_s: float = 1e-8,
        noise_sigma_m: float | None = None,
    ):
        self.relax = relax
        self.K = relax.n_modes
        self.index = {p: self.K + i for i, p in enumerate(poses)}
        n = self.K + len(poses)
        self.x = np.zeros((n, 3))
        self.P = np.eye(n) * prior_sigma_m**2
        self.prior_sigma_m = float(prior_sigma_m)
        self.q = float(process_noise_m2_per_s)
        sigma = relax.noise_sigma_m if noise_sigma_m is None else noise_sigma_m
        self.noise_sigma_m = float(sigma) if np.isfinite(sigma) else 1e-4
        self.H = np.zeros(n)
        self.H[: self.K] = relax.weight
        self.t_s = None  # time of the state, s
        self.n_outliers = 0

    def set(self, pose: str, mean_W, sigma_m: float) -> None:
        """Make ``pose`` (or ``"modes"``) a fresh, independent estimate.

        Parameters
        ----------
        pose : str
            A pose of the state, or ``"modes"`` for every relaxation mode.
        mean_W : array_like
            Its mean, shape (3,), in m in frame W.
        sigma_m : float
            Its std per axis (m).
        """
        rows = list(range(self.K)) if pose == "modes" else [self.index[pose]]
        for i in rows:
            self.P[i, :] = 0.0
            self.P[:, i] = 0.0
            self.P[i, i] = sigma_m**2
            self.x[i] = mean_W

    def jitter(self, pose: str, sigma_m: float) -> None:
        """``pose``'s equilibrium may differ from last time by ``sigma_m`` per axis (m): a
        pose reached along another path (cable play) is not quite the same pose.

        Parameters
        ----------
        pose : str
            A pose of the state.
        sigma_m : float
            Std per axis (m) added to its uncertainty.
        """
        i = self.index[pose]
        self.P[i, i] += sigma_m**2

    def forget(self, pose: str) -> None:
        """A new, unknown equilibrium for ``pose`` (the next sample's target): the filtered
        tip now, with the prior std.

        Parameters
        ----------
        pose : str
            A pose of the state.
        """
        self.set(pose, self.tip(), self.prior_sigma_m)

    def tip(self) -> np.ndarray:
        """The filtered tip now.

        Returns
        -------
        numpy.ndarray
            The tip, shape (3,), in m in frame W: the modes weighted by the relaxation.
        """
        return self.H @ self.x

    def std(self, pose: str) -> float:
        """The uncertainty of ``pose``'s equilibrium.

        Parameters
        ----------
        pose : str
            A pose of the state.

        Returns
        -------
        float
            Its std per axis (m).
        """
        return float(np.sqrt(self.P[self.index[pose], self.index[pose]]))

    def advance(self, t_s: float, pose_from: str, pose_to: str, s0: float, s1: float) -> None:
        """Move the state to time ``t_s`` while the equilibrium goes linearly from
        ``pose_from (1 - s0) + pose_to s0`` to ``... s1`` (s: fraction of the move done).
        The first call only sets the state's time.

        Parameters
        ----------
        t_s : float
            The new time (s, rig clock); no earlier time changes nothing.
        pose_from, pose_to : str
            The poses the move goes from and to.
        s0, s1 : float
            Fraction (0..1) of the move done at the state's time and at ``t_s``.
        """
        if self.t_s is None:
            self.t_s = float(t_s)
            return
        dt = float(t_s) - self.t_s
        if dt <= 0:
            return
        decay, g_a, g_b = self.relax.interval(dt, s0, s1)
        n = len(self.x)
        F = np.eye(n)
        F[: self.K, : self.K] = np.diag(decay)
        a, b = self.index[pose_from], self.index[pose_to]
        F[: self.K, a] += g_a
        F[: self.K, b] += g_b
        self.x = F @ self.x
        self.P = F @ self.P @ F.T
        self.P[: self.K, : self.K] += self.q * dt * np.eye(self.K)
        self.t_s = float(t_s)

    def update(self, reading_W, n_frames: int) -> float:
        """Fold in one reading (3,) m, the mean of ``n_frames`` frames; NaN readings and
        readings of no frame change nothing. Returns the normalised innovation squared (per
        axis, mean), NaN when skipped. A reading far outside the prediction (> 5 sigma on
        average) widens the modes instead of being trusted: the model did not expect it.

        Parameters
        ----------
        reading_W : array_like
            The reading, shape (3,), in m in frame W.
        n_frames : int
            Frames averaged into it (its noise variance is ``sigma^2 / n_frames``).

        Returns
        -------
        float
            The normalised innovation squared (per axis, mean), NaN when skipped.
        """
        reading_W = np.asarray(reading_W, float)
        if n_frames <= 0 or not np.all(np.isfinite(reading_W)):
            return float("nan")
        r = self.noise_sigma_m**2 / n_frames
        S = float(self.H @ self.P @ self.H) + r
        innovation = reading_W - self.H @ self.x
        nis = float(np.mean(innovation**2) / S)
        if nis > 25.0:
            self.n_outliers += 1
            self.P[: self.K, : self.K] += np.eye(self.K) * float(np.mean(innovation**2))
            S = float(self.H @ self.P @ self.H) + r
        gain = self.P @ self.H / S
        self.x = self.x + np.outer(gain, innovation)
        self.P = self.P - S * np.outer(gain, gain)
        self.P = 0.5 * (self.P + self.P.T)
        return nis
