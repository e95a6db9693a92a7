"""``MocapModel``: how the emulated motion capture sees a marker -- noise and occlusion bursts.

The twin rig (:class:`~lab.rig.twin.TwinRig`) passes the true tip of its as-built body
through this model once per frame: Gaussian noise per axis and occlusion bursts reported as
NaN frames, drawn in blocks from one seeded generator so that the sequence depends only on
the seed. A robot's other markers (:meth:`MocapModel.observe_markers`) get their own noise
from a second generator of the same seed, so the tip's sequence is the same with or
without them, and are hidden with it (one occlusion process per frame). The defects file
gives the parameters (``[mocap]``); the design:
``docs/design/rig.md``.
"""

from __future__ import annotations

import numpy as np

from lab.asbuilt.arm import Defects


class MocapModel:
    """Motion-capture observation of a marker: per-axis Gaussian noise of
    ``noise_sigma_m`` and occlusion bursts starting with probability ``dropout_rate_hz /
    frame_rate_hz`` at each frame, each 1..``dropout_max_frames`` frames long (uniform),
    reported as NaN, with at least one seen frame between two bursts. Every frame
    consumes the same random numbers, so the sequence depends only on the seed.

    Parameters
    ----------
    frame_rate_hz : float
        Frame rate of the motion capture (Hz).
    noise_sigma_m : float
        Standard deviation of the Gaussian noise per axis (m).
    dropout_rate_hz : float
        Rate at which occlusion bursts start (1/s).
    dropout_max_frames : int
        Longest burst (frames); lengths are uniform in 1..``dropout_max_frames``.
    seed : int
        Seed of the noise and the bursts.
    """

    _BLOCK = 4096

    def __init__(
        self, frame_rate_hz: float, noise_sigma_m: float, dropout_rate_hz: float, dropout_max_frames: int, seed: int = 0
    ):
        self.noise_sigma_m = float(noise_sigma_m)
        self.p_burst_start = float(dropout_rate_hz) / float(frame_rate_hz)
        self.dropout_max_frames = int(dropout_max_frames)
        self._rng = np.random.default_rng(seed)
        self._marker_rng = np.random.default_rng([int(seed), 1])  # the other markers' noise
        self._i = self._BLOCK
        self._left = 0  # frames still occluded in the current burst
        self._burst_ended = False  # a burst ended last frame: this one is seen
        self.n_frames = self.n_dropped = 0

    @classmethod
    def from_defects(cls, defects: Defects, seed: int = 0) -> MocapModel:
        """The motion capture a defects file describes (its ``[mocap]`` table).

        Parameters
        ----------
        defects : Defects
            The as-built robot's defects (frame rate, noise, dropouts).
        seed : int
            Seed of the noise and the bursts.

        Returns
        -------
        MocapModel
            The observation model.
        """
        return cls(
            defects.frame_rate_hz, defects.noise_sigma_m, defects.dropout_rate_hz, defects.dropout_max_frames, seed
        )

    def observe(self, p_true_W: np.ndarray) -> np.ndarray:
        """One frame's measurement of the true marker position.

        Parameters
        ----------
        p_true_W : numpy.ndarray
            True marker position, shape (3,), in m in the frame W.

        Returns
        -------
        numpy.ndarray
            The measured position, shape (3,), in m, or all-NaN while occluded.
        """
        if self._i == self._BLOCK:
            self._noise = self.noise_sigma_m * self._rng.standard_normal((self._BLOCK, 3))
            self._start = self._rng.random(self._BLOCK)
            self._length = self._rng.integers(1, self.dropout_max_frames + 1, self._BLOCK)
            self._i = 0
        i = self._i
        self._i += 1
        self.n_frames += 1
        if self._left == 0 and not self._burst_ended and self._start[i] < self.p_burst_start:
            self._left = int(self._length[i])
        self._burst_ended = False
        if self._left > 0:
            self._left -= 1
            self.n_dropped += 1
            self._burst_ended = self._left == 0
            return np.full(3, np.nan)
        return p_true_W + self._noise[i]

    def observe_markers(self, points_true_W: np.ndarray) -> np.ndarray:
        """One frame's measurement of every marker: the tip (row 0) by :meth:`observe`, the
        others with their own Gaussian noise, all NaN in a frame the tip is occluded in.

        Parameters
        ----------
        points_true_W : numpy.ndarray
            True marker positions, shape (K, 3), in m in the frame W, the tip first.

        Returns
        -------
        numpy.ndarray
            The measured positions, shape (K, 3), in m; every row NaN while occluded.
        """
        p = np.asarray(points_true_W, dtype=float).reshape(-1, 3)
        out = np.empty_like(p)
        out[0] = self.observe(p[0])
        noise = self.noise_sigma_m * self._marker_rng.standard_normal((len(p) - 1, 3))
        out[1:] = p[1:] + noise if np.all(np.isfinite(out[0])) else np.nan
        return out
