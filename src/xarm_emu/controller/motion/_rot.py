"""Small rotation helpers for the path generators: unit quaternions ``(w, x, y, z)``
as plain tuples (cheap to evaluate every 4 ms) and 4x4 pose matrices in mm
(manual 1.5: R = Rz(yaw) Ry(pitch) Rx(roll); the matrices already carry it).

:func:`pose_matrices`, :meth:`Slerp.at_many` and :class:`SlerpSet` do the same for many
samples at once on numpy arrays. They
evaluate every expression of their scalar twins in the same order (a difference
``a - b`` as ``a + (-1 * b)``, which is exact), so they give the same bits as
long as numpy's ``sin`` and ``cos`` give those of :mod:`math`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ...model.rotations import Quat, quat_from_matrix

__all__ = ["Quat", "Slerp", "pose_matrices", "pose_matrix", "quat_conj", "quat_from_matrix", "quat_mul",
           "SlerpSet"]


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


#: ``pose_matrices``: the nine rotation entries (row-major) are ``2 (p[A] + SIGN p[B])``, the diagonal
#: ``1 - 2 (...)``, from the products ``p = (xx, yy, zz, xy, xz, yz, wx, wy, wz)`` as in :func:`pose_matrix`.
_PROD_I = np.array((1, 2, 3, 1, 1, 2, 0, 0, 0))
_PROD_J = np.array((1, 2, 3, 2, 3, 3, 1, 2, 3))
_SUM_A = np.array((1, 3, 4, 3, 0, 5, 4, 5, 0))
_SUM_B = np.array((2, 8, 7, 8, 2, 6, 7, 6, 1))
_SUM_SIGN = np.array((1.0, -1.0, 1.0, 1.0, 1.0, -1.0, -1.0, 1.0, 1.0))
_DIAG = np.array((0, 4, 8))
_LAST_ROW = np.array((0.0, 0.0, 0.0, 1.0))


def pose_matrices(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """:func:`pose_matrix` of each row: positions ``p`` (N, 3), unit quaternions ``q`` (N, 4) ->
    (N, 4, 4)."""
    n = len(q)
    prod = q[:, _PROD_I] * q[:, _PROD_J]
    r = 2.0 * (prod[:, _SUM_A] + prod[:, _SUM_B] * _SUM_SIGN)
    r[:, _DIAG] = 1.0 - r[:, _DIAG]
    out = np.empty((n, 4, 4))
    out[:, :3, :3] = r.reshape(n, 3, 3)
    out[:, :3, 3] = p
    out[:, 3] = _LAST_ROW
    return out


#: ``quat_mul(a, b)`` with ``a`` fixed: component ``k`` is the sum, in this order, of
#: ``coefficient[k, m] * b[_MUL_INDEX[k, m]]``; the coefficients are ``_MUL_SIGN * a[_MUL_A]``.
_MUL_INDEX = np.array(((0, 1, 2, 3), (1, 0, 3, 2), (2, 3, 0, 1), (3, 2, 1, 0)))
_MUL_SIGN = np.array(((1.0, -1.0, -1.0, -1.0), (1.0, 1.0, 1.0, -1.0), (1.0, -1.0, 1.0, 1.0),
                      (1.0, 1.0, -1.0, 1.0)))
_MUL_A = np.array(((0, 1, 2, 3),) * 4)


def _left_factors(a: Quat) -> np.ndarray:
    """The (4, 4) coefficients with which ``quat_mul(a, b)`` weighs the entries of ``b``."""
    return _MUL_SIGN * np.array(a)[_MUL_A]


class Slerp:
    """Shortest-rotation interpolation from ``q0`` (u=0) to ``q1`` (u=1).

    ``angle`` is the rotation angle in rad (0..pi): the sign of ``q1`` is chosen
    so the interpolation never takes the long way round.
    """

    __slots__ = ("q0", "q1", "angle", "_axis", "_many")

    def __init__(self, q0: Quat, q1: Quat) -> None:
        rel = quat_mul(quat_conj(q0), q1)
        if rel[0] < 0.0:
            rel = (-rel[0], -rel[1], -rel[2], -rel[3])
        vn = math.sqrt(rel[1] ** 2 + rel[2] ** 2 + rel[3] ** 2)
        self.q0, self.q1 = q0, q1
        self._many: SlerpSet | None = None
        self.angle = 2.0 * math.atan2(vn, rel[0])
        self._axis = (rel[1] / vn, rel[2] / vn, rel[3] / vn) if vn > 1e-15 else (0.0, 0.0, 0.0)

    @property
    def axis(self) -> tuple[float, float, float]:
        """Unit rotation axis in the frame of ``q0`` (zeros for no rotation)."""
        return self._axis

    def at_many(self, u: np.ndarray) -> np.ndarray:
        """:meth:`at` of each entry of ``u`` (N,) -> (N, 4)."""
        many = self._many
        if many is None:
            many = self._many = SlerpSet((self,))
        return many.at(None, u)

    def at(self, u: float) -> Quat:
        if self.angle == 0.0 or u <= 0.0:
            return self.q0
        if u >= 1.0:
            return self.q1
        h = 0.5 * u * self.angle
        s = math.sin(h)
        ax, ay, az = self._axis
        return quat_mul(self.q0, (math.cos(h), ax * s, ay * s, az * s))



class SlerpSet:
    """Several :class:`Slerp` evaluated at once: ``at(which, u)[k] == slerps[which[k]].at(u[k])``."""

    __slots__ = ("_factors", "_q0", "_q1", "_axis", "_angle")

    def __init__(self, slerps: Sequence[Slerp]) -> None:
        self._factors = np.array([_left_factors(sl.q0) for sl in slerps])  # (K, 4, 4)
        self._q0 = np.array([sl.q0 for sl in slerps])
        self._q1 = np.array([sl.q1 for sl in slerps])
        self._axis = np.array([sl.axis for sl in slerps])
        self._angle = np.array([sl.angle for sl in slerps])

    def at(self, which: np.ndarray | None, u: np.ndarray) -> np.ndarray:
        """Unit quaternions (N, 4); ``which=None``: every entry from the first slerp."""
        if which is None:
            ang, axis, factors = self._angle[0], self._axis[0], self._factors[0]
        else:
            ang, axis, factors = self._angle[which], self._axis[which], self._factors[which]
        h = 0.5 * u * ang
        sn = np.sin(h)
        b = np.empty((len(u), 4))
        b[:, 0] = np.cos(h)
        b[:, 1:] = axis * sn[:, None]
        terms = factors * b[:, _MUL_INDEX]
        q = terms[:, :, 0] + terms[:, :, 1] + terms[:, :, 2] + terms[:, :, 3]
        late = u >= 1.0
        if late.any():
            q[late] = self._q1[0] if which is None else self._q1[which[late]]
        early = (u <= 0.0) | (ang == 0.0)
        if early.any():
            q[early] = self._q0[0] if which is None else self._q0[which[early]]
        return q
