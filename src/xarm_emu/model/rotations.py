"""Orientation conventions: roll/pitch/yaw, axis-angle, and pose <-> 4x4 matrix (mm, rad).

Manual 1.5 "Roll/Pitch/Yaw": fixed X-Y-Z angles, R = Rz(yaw) Ry(pitch) Rx(roll). Manual 1.5 "Axis-Angle":
[Rx, Ry, Rz] = unit axis * phi with phi >= 0.

Vendor canonical form of matrix_to_rpy (what the vendor controller reports; manual register 44 example):
- each angle lies in [-pi, pi]; on the roll seam (|r21| < 1e-12 with r22 < 0) roll is reported as -pi;
- a pitch with |pitch| < 1e-12 is reported as -0.0 (register 44 example bytes 00 00 00 80);
- a yaw with |yaw| < 1e-12 (outside gimbal lock) is reported as +0.0;
- at gimbal lock (|pitch -/+ pi/2| < GIMBAL_TOL) pitch is exactly +/-pi/2, yaw is kept 0 and the whole
  rotation about z goes into roll (vendor article: [0, 90, 30] deg reads back as [-30, 90, 0] deg).

Axis-angle sign rule at exactly phi = pi (where +axis and -axis give the same rotation): the first
component of the axis whose magnitude exceeds 1e-12 is made positive, so the zero pose reads [pi, 0, 0]
as in the manual's example.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

SEAM_TOL = 1e-12
ZERO_TOL = 1e-12
# |cos(pitch)| below this counts as gimbal lock: covers any float32-rounded +/-pi/2 (6e-8 away).
GIMBAL_TOL = 1e-6
POSITION_SNAP = 1e-9  # mm; tidier output for numeric noise, e.g. y = 3.6e-14 at zero joints

#: Unit quaternion ``(w, x, y, z)``.
Quat = tuple[float, float, float, float]


def _finite(*values: float) -> None:
    for v in values:
        if not math.isfinite(v):
            raise ValueError(f"non-finite value {v!r} in rotation")


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """3x3 R = Rz(yaw) Ry(pitch) Rx(roll) (manual 1.5). ValueError on NaN/inf."""
    _finite(roll, pitch, yaw)
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_to_rpy(R: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw of a rotation matrix in the vendor canonical form (see module docstring)."""
    r00, r01 = float(R[0][0]), float(R[0][1])
    r10, r11 = float(R[1][0]), float(R[1][1])
    r20, r21, r22 = float(R[2][0]), float(R[2][1]), float(R[2][2])
    _finite(r00, r01, r10, r11, r20, r21, r22)
    cp = math.hypot(r00, r10)
    if cp < GIMBAL_TOL:
        if r20 < 0.0:  # pitch = +pi/2: only roll - yaw is defined
            return np.array([_seam(math.atan2(r01, r11)), math.pi / 2, 0.0])
        return np.array([_seam(math.atan2(-r01, r11)), -math.pi / 2, 0.0])
    pitch = math.atan2(-r20, cp)
    if abs(pitch) < ZERO_TOL:
        pitch = -0.0
    if abs(r21) < SEAM_TOL and r22 < 0.0:
        roll = -math.pi
    else:
        roll = math.atan2(r21, r22)
    yaw = math.atan2(r10, r00)
    if abs(yaw) < ZERO_TOL:
        yaw = 0.0
    return np.array([roll, pitch, yaw])


def _seam(angle: float) -> float:
    """Map +pi (and values within SEAM_TOL of it) to -pi, as the vendor reports the seam."""
    return -math.pi if abs(abs(angle) - math.pi) < SEAM_TOL else angle


def canonical_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """The vendor canonical form of any roll/pitch/yaw triple."""
    return matrix_to_rpy(rpy_to_matrix(roll, pitch, yaw))


def axis_angle_to_matrix(rv: Sequence[float] | np.ndarray) -> np.ndarray:
    """3x3 rotation of the rotation vector [Rx, Ry, Rz] = axis * phi (manual 1.5, Rodrigues)."""
    x, y, z = float(rv[0]), float(rv[1]), float(rv[2])
    _finite(x, y, z)
    th = math.sqrt(x * x + y * y + z * z)
    if th < 1e-12:
        return np.array([[1.0, -z, y], [z, 1.0, -x], [-y, x, 1.0]])
    kx, ky, kz = x / th, y / th, z / th
    c, s = math.cos(th), math.sin(th)
    v = 1.0 - c
    return np.array(
        [
            [c + kx * kx * v, kx * ky * v - kz * s, kx * kz * v + ky * s],
            [ky * kx * v + kz * s, c + ky * ky * v, ky * kz * v - kx * s],
            [kz * kx * v - ky * s, kz * ky * v + kx * s, c + kz * kz * v],
        ]
    )


def matrix_to_axis_angle(R: np.ndarray) -> np.ndarray:
    """Rotation vector axis * phi with phi in [0, pi]; sign rule at phi = pi in the module docstring."""
    R = np.asarray(R, dtype=float)
    if not np.all(np.isfinite(R[:3, :3])):
        raise ValueError("non-finite value in rotation matrix")
    vx = R[2, 1] - R[1, 2]
    vy = R[0, 2] - R[2, 0]
    vz = R[1, 0] - R[0, 1]
    s2 = math.sqrt(vx * vx + vy * vy + vz * vz)  # 2 sin(phi)
    c = (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) / 2.0  # cos(phi)
    phi = math.atan2(s2 / 2.0, c)
    if c > -0.9:  # phi < ~154 deg: the skew part is well conditioned
        if s2 < 1e-300:
            return np.zeros(3)
        k = phi / s2
        return np.array([vx * k, vy * k, vz * k])
    # Near pi: axis from the symmetric part, (R + R^T)/2 = c I + (1 - c) a a^T.
    M = ((R[:3, :3] + R[:3, :3].T) / 2.0 - c * np.eye(3)) / (1.0 - c)  # = a a^T
    i = int(np.argmax(np.diag(M)))
    a = M[:, i] / math.sqrt(M[i, i])
    a /= np.linalg.norm(a)
    if s2 > 1e-12:
        if a[0] * vx + a[1] * vy + a[2] * vz < 0.0:
            a = -a
    else:
        for comp in a:
            if abs(comp) > 1e-12:
                if comp < 0.0:
                    a = -a
                break
    return a * phi


def pose_to_matrix(pose: Sequence[float] | np.ndarray) -> np.ndarray:
    """4x4 homogeneous transform of (x, y, z, roll, pitch, yaw) in mm/rad."""
    T = np.eye(4)
    T[:3, :3] = rpy_to_matrix(pose[3], pose[4], pose[5])
    _finite(float(pose[0]), float(pose[1]), float(pose[2]))
    T[:3, 3] = (pose[0], pose[1], pose[2])
    return T


def matrix_to_pose(T: np.ndarray) -> np.ndarray:
    """(x, y, z, roll, pitch, yaw) of a 4x4 transform, canonical RPY, |x|,|y|,|z| < 1e-9 mm snapped to 0."""
    out = np.empty(6)
    out[3:] = matrix_to_rpy(T)
    for i in range(3):
        v = float(T[i][3])
        _finite(v)
        out[i] = 0.0 if abs(v) < POSITION_SNAP else v
    return out


def pose_aa_to_matrix(pose: Sequence[float] | np.ndarray) -> np.ndarray:
    """4x4 transform of (x, y, z, Rx, Ry, Rz) (axis-angle orientation, manual 1.5)."""
    T = np.eye(4)
    T[:3, :3] = axis_angle_to_matrix(pose[3:6])
    _finite(float(pose[0]), float(pose[1]), float(pose[2]))
    T[:3, 3] = (pose[0], pose[1], pose[2])
    return T


def matrix_to_pose_aa(T: np.ndarray) -> np.ndarray:
    """(x, y, z, Rx, Ry, Rz) of a 4x4 transform."""
    out = np.empty(6)
    out[3:] = matrix_to_axis_angle(np.asarray(T)[:3, :3])
    for i in range(3):
        v = float(T[i][3])
        _finite(v)
        out[i] = 0.0 if abs(v) < POSITION_SNAP else v
    return out


def rpy_to_axis_angle(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation vector of a roll/pitch/yaw triple."""
    return matrix_to_axis_angle(rpy_to_matrix(roll, pitch, yaw))


def axis_angle_to_rpy(rv: Sequence[float]) -> np.ndarray:
    """Canonical roll/pitch/yaw of a rotation vector."""
    return matrix_to_rpy(axis_angle_to_matrix(rv))


def invert_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of a rigid 4x4 transform."""
    Ti = np.eye(4)
    Rt = T[:3, :3].T
    Ti[:3, :3] = Rt
    Ti[:3, 3] = -Rt @ T[:3, 3]
    return Ti


def wrap_to_pi(angle: float) -> float:
    """Angle mapped into [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def snap_seam(angle: float, tol: float = 1e-6) -> float:
    """+/-pi for an angle within ``tol`` of +/-pi, else the angle unchanged.

    Wire angles are float32: float32(pi) = pi + 8.7e-8. The vendor's register 43 answer shows the
    controller treats it as pi exactly, so the register layer applies this to
    incoming roll/pitch/yaw.
    """
    if abs(abs(angle) - math.pi) <= tol:
        return math.copysign(math.pi, angle)
    return angle


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
