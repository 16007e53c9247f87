"""Commands that wait in the command buffer (manual section 2.1.3, registers
21-28 and 92), as the controller stores them after validation."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class JointMove:
    """Register 23 (and 24 with a blend radius, 25 go home): P2P joint motion."""

    register: int
    target: np.ndarray  # rad, length dof
    speed: float  # rad/s
    acc: float  # rad/s^2
    radius: float = -1.0
    relative: bool = False  # register 83: ``target`` is a delta added to the joints at the start


@dataclass(frozen=True)
class LineMove:
    """Registers 21, 22, 28, 92: a straight TCP line to a pose.

    ``target`` is the TCP pose as a 4x4 matrix in the user frame (mm), already
    resolved from tool-frame or relative forms when the move starts.
    """

    register: int
    pose: tuple[float, ...]  # as sent: x, y, z and RPY or axis-angle
    speed: float  # mm/s
    acc: float  # mm/s^2
    radius: float = -1.0  # arc blending radius (register 22), -1 = none
    tool_frame: bool = False  # register 28 / 92 coordinate 1
    relative: bool = False  # register 92 "relative pose"
    axis_angle: bool = False  # register 92
    motion_type: int = 0  # register 21's common form: 1 line or joint fallback, 2 joint planning


@dataclass(frozen=True)
class CircleMove:
    """Register 27: circle through the current point, pose1 and pose2."""

    register: int
    pose1: tuple[float, ...]
    pose2: tuple[float, ...]
    speed: float
    acc: float
    percent: float


@dataclass(frozen=True)
class Dwell:
    """Register 26: pause the queue for ``seconds``."""

    register: int
    seconds: float


@dataclass(frozen=True)
class Task:
    """A non-motion command that waits its turn in the buffer (the counter of registers 74/75, IO
    sent with the sync byte, position triggers queued behind moves): ``run`` is called when the
    buffer reaches it, and it takes one control period."""

    register: int
    run: Callable[[], None]


QueuedCommand = JointMove | LineMove | CircleMove | Dwell | Task
