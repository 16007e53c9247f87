"""Small rotation helpers for the path generators: unit quaternions ``(w, x, y, z)``
as plain tuples (cheap to evaluate every 4 ms) and 4x4 pose matrices in mm
(manual 1.5: R = Rz(yaw) Ry(pitch) Rx(roll); the matrices already carry it).
"""

from __future__ import annotations

import math

import numpy as np

from ...model.rotations import Quat, quat_from_matrix

__all__ = ["Quat", "Slerp", "pose_matrix", "quat_conj", "quat_from_matrix", "quat_mul"]


def quat_mul(a: Quat, b: Quat) -> Quat:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def quat_conj(q: Quat) -> Quat:
    return (q[0], -q[1], -q[2], -q[3])


def pose_matrix(p: tuple[float, float, float], q: Quat) -> np.ndarray:
    """4x4 homogeneous pose from a position (mm) and a unit quaternion."""
    w, x, y, z = q
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    wx, wy, wz = w * x, w * y, w * z
    return np.array((  # one flat sequence, reshaped: cheaper than nested rows
        1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy), p[0],
        2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx), p[1],
        2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy), p[2],
        0.0, 0.0, 0.0, 1.0,
    )).reshape(4, 4)


class Slerp:
    """Shortest-rotation interpolation from ``q0`` (u=0) to ``q1`` (u=1).

    ``angle`` is the rotation angle in rad (0..pi): the sign of ``q1`` is chosen
    so the interpolation never takes the long way round.
    """

    __slots__ = ("q0", "q1", "angle", "_axis")

    def __init__(self, q0: Quat, q1: Quat) -> None:
        rel = quat_mul(quat_conj(q0), q1)
        if rel[0] < 0.0:
            rel = (-rel[0], -rel[1], -rel[2], -rel[3])
        vn = math.sqrt(rel[1] ** 2 + rel[2] ** 2 + rel[3] ** 2)
        self.q0, self.q1 = q0, q1
        self.angle = 2.0 * math.atan2(vn, rel[0])
        self._axis = (rel[1] / vn, rel[2] / vn, rel[3] / vn) if vn > 1e-15 else (0.0, 0.0, 0.0)

    def at(self, u: float) -> Quat:
        if self.angle == 0.0 or u <= 0.0:
            return self.q0
        if u >= 1.0:
            return self.q1
        h = 0.5 * u * self.angle
        s = math.sin(h)
        ax, ay, az = self._axis
        return quat_mul(self.q0, (math.cos(h), ax * s, ay * s, az * s))
