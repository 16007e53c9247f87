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


#: ``pose_matrices``: the rows of ``big`` are the products ``(2 q[i]) q[j]`` (rows ``4 i + j``) and
#: ``(-2 q[i]) q[j]`` (rows ``16 + 4 i + j``), then the position and a row of -0.0. The first twelve
#: rows of the matrix (row-major) are ``big[_TERM_A] + big[_TERM_B]``: for the rotation the two terms
#: of :func:`pose_matrix`'s ``2 (a + b)`` or ``2 (a - b)`` with the factor 2 (exact) taken inside,
#: for the position ``p + (-0.0)``, which is ``p``; the diagonal is then ``1 - ...``.
_PRODUCTS = ((1, 1), (2, 2), (3, 3), (1, 2), (1, 3), (2, 3), (0, 1), (0, 2), (0, 3))
_XX, _YY, _ZZ, _XY, _XZ, _YZ, _WX, _WY, _WZ = (4 * i + j for i, j in _PRODUCTS)
_P, _NEG0 = 32, 35
_TERMS = np.array((_YY, _XY, _XZ, _P, _XY, _XX, _YZ, _P + 1, _XZ, _YZ, _XX, _P + 2,
                   _ZZ, 16 + _WZ, _WY, _NEG0, _WZ, _ZZ, 16 + _WX, _NEG0, 16 + _WY, _WX, _YY, _NEG0))
_DOUBLE = np.array((2.0, -2.0))[:, None, None]
_LAST_ROW = np.array((0.0, 0.0, 0.0, 1.0))[:, None]


def pose_matrices(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """:func:`pose_matrix` of each column: positions ``p`` (3, N), unit quaternions ``q`` (4, N) ->
    (N, 4, 4).

    The work is done on rows of N samples (each a contiguous vector) and transposed once at the end.
    """
    n = q.shape[1]
    big = np.empty((36, n))
    np.multiply((_DOUBLE * q).reshape(8, 1, n), q, out=big[:32].reshape(8, 4, n))
    big[32:35] = p
    big[35] = -0.0
    terms = big.take(_TERMS, axis=0)
    flat = np.empty((16, n))
    np.add(terms[:12], terms[12:], out=flat[:12])
    diagonal = flat[0:11:5]
    np.subtract(1.0, diagonal, out=diagonal)
    flat[12:] = _LAST_ROW
    return np.ascontiguousarray(flat.T).reshape(n, 4, 4)


#: ``quat_mul(a, b)`` with ``a`` fixed: component ``k`` is the sum over the terms ``m = 0..3``, in this
#: order, of ``factor[4 m + k] * b[_MUL_INDEX[4 m + k]]``, the factors being ``_MUL_SIGN * a[_MUL_A]``.
_MUL_INDEX = np.array((0, 1, 2, 3, 1, 0, 3, 2, 2, 3, 0, 1, 3, 2, 1, 0)).reshape(4, 4).T.ravel()
_MUL_SIGN = np.array((1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0, -1.0, 1.0, -1.0, 1.0, 1.0, 1.0, 1.0, -1.0,
                      1.0)).reshape(4, 4).T.ravel()
_MUL_A = np.array((0, 1, 2, 3) * 4).reshape(4, 4).T.ravel()


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
        """:meth:`at` of each entry of ``u`` (N,) -> unit quaternions as columns (4, N)."""
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
    """Several :class:`Slerp` evaluated at once: column ``k`` of ``at(which, u)`` is
    ``slerps[which[k]].at(u[k])``."""

    __slots__ = ("_table", "_zero_angle")

    #: Rows of the table: the slerp's angle, its axis, the 16 factors of ``quat_mul(q0, .)``, q0, q1.
    _ANGLE, _AXIS, _FACTORS, _Q0, _Q1 = 0, slice(1, 4), slice(4, 20), slice(20, 24), slice(24, 28)

    def __init__(self, slerps: Sequence[Slerp]) -> None:
        self._table = np.array([(sl.angle, *sl.axis, *(_MUL_SIGN * np.array(sl.q0)[_MUL_A]), *sl.q0, *sl.q1)
                                for sl in slerps]).T.copy()
        self._zero_angle = any(sl.angle == 0.0 for sl in slerps)

    def at(self, which: np.ndarray | None, u: np.ndarray) -> np.ndarray:
        """Unit quaternions (4, N) at the fractions ``u`` (N,); ``which=None``: all from the first slerp."""
        n = len(u)
        if which is None:
            tab = self._table[:, :1]
            if self._table[self._ANGLE, 0] == 0.0:  # no rotation: q0 throughout
                return np.repeat(tab[self._Q0], n, axis=1)
        else:
            tab = self._table.take(which, axis=1)
        ang = tab[self._ANGLE]
        h = 0.5 * u * ang
        b = np.empty((4, n))
        np.cos(h, out=b[0])
        np.multiply(tab[self._AXIS], np.sin(h), out=b[1:])
        terms = (tab[self._FACTORS] * b.take(_MUL_INDEX, axis=0)).reshape(4, 4, n)
        q = terms[0] + terms[1]
        q += terms[2]
        q += terms[3]
        late = u >= 1.0
        if np.count_nonzero(late):
            q[:, late] = tab[self._Q1] if which is None else tab[self._Q1][:, late]
        early = u <= 0.0
        if self._zero_angle and which is not None:
            early |= ang == 0.0
        if np.count_nonzero(early):
            q[:, early] = tab[self._Q0] if which is None else tab[self._Q0][:, early]
        return q
