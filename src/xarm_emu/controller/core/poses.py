"""Poses as the motion registers carry them (manual 2.1.3, registers 21-30, 43, 76, 92, 93): wire
poses to matrices, and where relative and tool-frame commands go."""

from __future__ import annotations

import numpy as np

from ...model import rotations as rot
from .commands import LineMove


def wire_pose_to_matrix(pose: tuple[float, ...] | np.ndarray) -> np.ndarray:
    """A pose as received on the wire (x, y, z mm; roll, pitch, yaw rad as float32) to a 4x4
    matrix; float32(pi) is read as pi (the manual's register 43 example)."""
    p = [float(x) for x in pose]
    return rot.pose_to_matrix(p[:3] + [rot.snap_seam(a) for a in p[3:6]])


def resolve_line_target(cmd: LineMove, start: np.ndarray) -> np.ndarray:
    """The absolute target (4x4, user frame) of a linear move from ``start``.

    - base frame, absolute: the pose as given;
    - base frame, relative (register 92): position added, rotation applied in the base frame;
    - tool frame (registers 28, 92 with coordinate 1): the pose is a motion of the tool frame,
      T_target = T_start * T_pose.
    """
    to_matrix = rot.pose_aa_to_matrix if cmd.axis_angle else wire_pose_to_matrix
    delta = to_matrix(np.asarray(cmd.pose, dtype=float))
    return apply_offset(start, delta, cmd.tool_frame, cmd.relative)


def apply_offset(start: np.ndarray, delta: np.ndarray, tool_frame: bool, relative: bool) -> np.ndarray:
    """Where a pose command goes from ``start``: tool frame (T_start * T_delta), relative in the base
    frame (position added, rotation applied in the base frame), or absolute (``delta`` itself)."""
    if tool_frame:
        return start @ delta
    if relative:
        out = np.eye(4)
        out[:3, :3] = delta[:3, :3] @ start[:3, :3]
        out[:3, 3] = start[:3, 3] + delta[:3, 3]
        return out
    return delta
