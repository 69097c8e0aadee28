"""The root (pelvis) speed as two LOF columns (``LOFConfig.root_speed_max``), causally.

Bone angles and inclinations do not see where the body goes: a step from standing into jogging
on the spot, sneaking or a hop changes them little, the pelvis speed a lot (why these columns
and their scale: ``docs/decisions.md``, Cuts, "The root speeds"). Speeds are in body scales per
second (the mean length of the 8 limb bones in the same frame, about 0.35 m on an adult), so no
length unit is needed and people of every size are measured alike.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels import root_speed as _kr
from streamseg.config import LOFConfig
from streamseg.skeleton.bones import bone_point_indices, up_vector
from streamseg.state import Stateful

__all__ = ["NO_ROOT", "RootSpeed", "body_scale", "root_speed_columns"]


def body_scale(positions: np.ndarray, bones: np.ndarray) -> np.ndarray:
    """Mean length of the 8 limb bones per frame, in the positions' unit, shape (n,).

    ``bones``: :func:`streamseg.skeleton.bones.bone_point_indices` (row 0, the spine, is left
    out: its end points differ most between skeletons). NaN where a joint is NaN or the
    bones have no length.
    """
    p = np.asarray(positions, dtype=np.float64)
    limbs = bones[1:]
    s = np.linalg.norm(p[:, limbs[:, 1]] - p[:, limbs[:, 0]], axis=-1).mean(axis=1)
    return np.where(s > 0, s, np.nan)


class RootSpeed(Stateful):
    """Stateful: joint positions (n, J, 3) in, the two root-speed columns (n, 2) out.

    Column 0 is the horizontal, column 1 the vertical speed of the root over the last
    ``speed_lag_s`` (the lag of the angular speeds), in body scales per second, mapped to
    ``pi * min(speed / root_speed_max, 1)``: the same [0, pi] range as the angles, so they
    are histogrammed in the same bins. A frame's step is its root movement since the previous
    frame divided by that frame's body scale; a step faster than ``root_jump`` body scales per
    second counts as no motion (a tracker re-centring, or the joins of joined recordings,
    teleport the root). Frame ``t`` reads frames ``t - lag .. t`` only, so any split of a
    stream into blocks gives the columns of the whole array. A NaN step makes the ``lag``
    frames that include it NaN (the detector skips them). The first frame has step 0.

    Parameters
    ----------
    config : LOFConfig
        ``root_speed_max``, ``root_jump`` and ``speed_lag_s``.
    fps : float
    skeleton : Skeleton or sequence of joint names
        Selects the root (the first bone's parent point) and the limb bones of the scale.
    up : str or None
        Up axis of the positions; None: the skeleton's ``up``.

    Memory: ``lag + 1`` steps of 3 floats.
    """

    def __init__(self, config: LOFConfig, fps: float, skeleton, up: str | None = None):
        self.lag = config.frames(fps)["speed_lag"]
        self.fps = float(fps)
        bones = bone_point_indices(skeleton)
        self.root = int(bones[0, 0])
        self.limbs = np.ascontiguousarray(bones[1:], dtype=np.int64)
        self.up = up_vector(up or getattr(skeleton, "up", "y"))
        self.v_max = float(config.root_speed_max)
        self.jump = float(config.root_jump) / self.fps  # body scales per frame
        self._st = np.zeros(_kr.ST_SIZE, dtype=np.int64)
        self._ring = np.zeros((self.lag, 3))  # the last lag steps, in ring order
        self._prev = np.full(3, np.nan)  # the root of the previous frame
        self.reset()

    def reset(self) -> None:
        """Forget the past (after a gap): the next frame is a stream's first."""
        self._ring[:] = 0.0
        self._prev[:] = np.nan
        self._st[_kr.ST_POS] = 0
        self._st[_kr.ST_FRESH] = 1

    def __call__(self, positions: np.ndarray) -> np.ndarray:
        p = np.ascontiguousarray(positions, dtype=np.float64)
        out = np.empty((p.shape[0], 2))
        _kr.root_speeds(p, *self.kernel_args(), out)
        return out

    def kernel_args(self) -> tuple:
        """``(joint, limbs, up, st, ring, prev, jump, rate, v_max)``: the arguments of
        :func:`streamseg._kernels.root_speed.root_speeds` between the positions and the
        output; the kernel advances ``st``, ``ring`` and ``prev``, this object's state."""
        return (
            self.root,
            self.limbs,
            self.up,
            self._st,
            self._ring,
            self._prev,
            self.jump,
            self.fps / self.lag,
            self.v_max,
        )


#: :meth:`RootSpeed.kernel_args` of a stream without root speeds: ``limbs`` with no row
NO_ROOT = (
    0,
    np.zeros((0, 2), dtype=np.int64),
    np.zeros(3),
    np.zeros(2, dtype=np.int64),
    np.zeros((1, 3)),
    np.zeros(3),
    0.0,
    0.0,
    1.0,
)


def root_speed_columns(
    positions: np.ndarray,
    skeleton,
    fps: float,
    config: LOFConfig | None = None,
    up: str | None = None,
) -> np.ndarray:
    """:class:`RootSpeed` of a whole array of positions (n, J, 3): shape (n, 2)."""
    return RootSpeed(config or LOFConfig(), fps, skeleton, up)(positions)
