"""The one in-memory type every reader returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: World up-axis names a skeleton may declare.
UP_AXES = ("x", "y", "z", "-x", "-y", "-z")


@dataclass(frozen=True)
class Skeleton:
    """A kinematic tree.

    Parameters
    ----------
    names : tuple of str, length n_joints
        Joint names as the file names them. Index 0 is the root.
    parents : ndarray of int, shape (n_joints,)
        Index of each joint's parent, -1 for the root. Parents precede children.
    offsets : ndarray of float, shape (n_joints, 3)
        Rest-pose offset of each joint from its parent, in the recording's length unit.
    units : str
        Length unit of positions and offsets (free text, e.g. ``"inch*0.45"`` or ``"cm"``).
    up : str
        World up axis of the positions, one of ``x y z -x -y -z``: ``"y"`` in Acclaim ASF/AMC,
        BVH and Kinect camera space (features that use gravity read it).
    """

    names: tuple
    parents: np.ndarray
    offsets: np.ndarray
    units: str = "unknown"
    up: str = "y"

    def __post_init__(self):
        if self.up not in UP_AXES:
            raise ValueError(f"up={self.up!r} is invalid: expected one of {', '.join(UP_AXES)}")

    @property
    def n_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of joint ``name``; raises ``KeyError`` listing the known joints."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no joint {name!r}; joints are {', '.join(self.names)}") from None


@dataclass(frozen=True)
class Recording:
    """A motion-capture recording, posed.

    Parameters
    ----------
    fps : float
        Frames per second.
    skeleton : Skeleton
        Joint names, parents and rest offsets.
    positions : ndarray of float64, shape (n_frames, n_joints, 3)
        World positions of every joint per frame (forward kinematics done).
    rotations : ndarray of float64, shape (n_frames, n_joints, 3, 3), or None
        World (global) rotation matrix of each joint's frame, where the format has rotations.
    source : str
        The file the recording came from (for messages).
    metadata : dict
        Anything else the reader knows (format, angle unit, warnings such as a truncated frame).
    """

    fps: float
    skeleton: Skeleton
    positions: np.ndarray
    rotations: np.ndarray | None = None
    source: str = ""
    metadata: dict = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return int(self.positions.shape[0])

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return self.n_frames / self.fps

    def slice(self, start: int, stop: int) -> Recording:
        """Frames ``start:stop`` (0-based, stop exclusive) as a new recording."""
        rot = None if self.rotations is None else self.rotations[start:stop]
        return Recording(
            self.fps,
            self.skeleton,
            self.positions[start:stop],
            rot,
            self.source,
            dict(self.metadata),
        )
