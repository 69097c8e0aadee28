"""Causal (forward-only) version of the kinematic UKF, for live streams.

The offline four-pass filter needs the whole recording; live, each limb runs pass 1 only
(angles and bone lengths together), frame by frame, continuing from the previous chunk.
"""

from __future__ import annotations

import numpy as np

from streamseg.kinematics.model import (
    HINGES,
    INITIAL_ANGLE_STD,
    INITIAL_LOG_LENGTH_STD,
    LIMBS,
    N_ANGLES,
    SETTLE_STEPS,
    SETTLE_VAR,
    arm_points,
    initial_angles,
    leg_points,
    std_caps,
    unit,
)
from streamseg.kinematics.ukf import ukf_pass

__all__ = ["AngleTracker"]


class AngleTracker:
    """Forward UKF over the four limbs, fed chunk by chunk.

    Parameters
    ----------
    fps : float
    pelvis_dir : ndarray, shape (3,)
    lengths0 : ndarray, shape (12,)
        Initial bone lengths (body-scale units).
    position_noise, angle_speed, length_speed : float
        As in :func:`streamseg.kinematics.model.fit_angles`.
    """

    def __init__(self, fps, pelvis_dir, lengths0, *, position_noise=0.05, angle_speed=4.0,
                 length_speed=0.02):
        pdir = unit(np.asarray(pelvis_dir, dtype=np.float64))
        self._R = [None] * 4
        self._chains, self._x, self._P, self._Q, self.std_caps = [], [], [], [], []
        a0 = initial_angles()
        qa, ql = (angle_speed / fps) ** 2, (length_speed / fps) ** 2
        for limb, (asl, lsl, ysl) in enumerate(LIMBS):
            k = asl.stop - asl.start
            if limb < 2:
                def chain(X, k=k):
                    return np.concatenate(arm_points(X[:, :k], np.exp(X[:, k:])), axis=1)
            else:
                def chain(X, k=k):
                    return np.concatenate(leg_points(X[:, :k], np.exp(X[:, k:]), pdir), axis=1)
            self._chains.append(chain)
            self._x.append(np.concatenate([a0[asl], np.log(np.asarray(lengths0)[lsl])]))
            self._P.append(np.diag(np.concatenate([np.full(k, INITIAL_ANGLE_STD**2),
                                                   np.full(3, INITIAL_LOG_LENGTH_STD**2)])))
            self._Q.append(np.concatenate([np.full(k, qa), np.full(3, ql)]))
            self.std_caps.append(std_caps(k, 3))
            self._R[limb] = np.full(ysl.stop - ysl.start, position_noise**2)
        self._started = False

    def update(self, Y: np.ndarray) -> np.ndarray:
        """Filter a chunk of observations.

        Parameters
        ----------
        Y : ndarray, shape (n, 36)
            From :func:`streamseg.kinematics.model.observations` (with fixed scale and pelvis_dir).

        Returns
        -------
        ndarray, shape (n, 20)
            Filtered joint angles.
        """
        out = np.empty((Y.shape[0], N_ANGLES))
        if Y.shape[0] == 0:
            return out
        for limb, (asl, _, ysl) in enumerate(LIMBS):
            k = asl.stop - asl.start
            h, R = self._chains[limb], self._R[limb]
            x, P = self._x[limb], self._P[limb]
            if not self._started:
                for _ in range(SETTLE_STEPS):
                    _, x, P = ukf_pass(Y[:1, ysl], h, x, P, np.full(k + 3, SETTLE_VAR), R,
                                       max_std=self.std_caps[limb])
            X, x, P = ukf_pass(Y[:, ysl], h, x, P, self._Q[limb], R, max_std=self.std_caps[limb])
            self._x[limb], self._P[limb] = x, P
            out[:, asl] = X[:, :k]
        self._started = True
        out[:, HINGES] = np.abs(out[:, HINGES])
        return out
