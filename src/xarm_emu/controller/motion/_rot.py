"""Small rotation helpers for the path generators: unit quaternions ``(w, x, y, z)``
as plain tuples (cheap to evaluate every 4 ms) and 4x4 pose matrices in mm
(manual 1.5: R = Rz(yaw) Ry(pitch) Rx(roll); the matrices already carry it).
"""

from __future__ import annotations

import math

import numpy as np

Quat = tuple[float, float, float, float]


def quat_from_matrix(r: np.ndarray) -> Quat:
    """Unit quaternion (w >= 0) of a 3x3 rotation matrix (Shepperd's method)."""
    m00, m01, m02 = float(r[0, 0]), float(r[0, 1]), float(r[0, 2])
    m10, m11, m12 = float(r[1, 0]), float(r[1, 1]), float(r[1, 2])
    m20, m21, m22 = float(r[2, 0]), float(r[2, 1]), float(r[2, 2])
    tr = m00 + m11 + m22
    if tr > max(m00, m11, m22):
        s = 2.0 * math.sqrt(1.0 + tr)
        q = (0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s)
    elif m00 >= m11 and m00 >= m22:
        s = 2.0 * math.sqrt(max(1.0 + m00 - m11 - m22, 0.0))
        q = ((m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s)
    elif m11 >= m22:
        s = 2.0 * math.sqrt(max(1.0 + m11 - m00 - m22, 0.0))
        q = ((m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s)
    else:
        s = 2.0 * math.sqrt(max(1.0 + m22 - m00 - m11, 0.0))
        q = ((m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s)
    n = math.sqrt(sum(c * c for c in q))
    if q[0] < 0.0:
        n = -n
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


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
    return np.array((
        (1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy), p[0]),
        (2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx), p[1]),
        (2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy), p[2]),
        (0.0, 0.0, 0.0, 1.0),
    ))


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
