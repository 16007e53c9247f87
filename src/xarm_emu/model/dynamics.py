"""Joint torques of the xArm from its link inertials: gravity and inverse dynamics.

This is what register 55 (theoretical joint torque, manual "51~100 Other Robotic Arm Function") and the
report's joint torque field (bytes 60-87, manual 2.1.6) show.

Sign convention: a torque is the one the joint's motor must apply to its outgoing link, about the joint's
+z axis (right-hand rule), to hold the arm or to produce the given motion. At the xArm6 zero pose J2 is
negative (about -7.76 N.m for the HT_BR2 set), the sign of the manual's register 55 example.

Units: joint angles rad (velocities rad/s, accelerations rad/s^2), torques N.m, masses kg, gravity m/s^2.
The payload centre of mass is in mm in the flange frame (register 36, like the wire). Lengths are
converted to metres internally.

Gravity: ``gravity`` is a vector in the base frame carrying direction *and* magnitude. Register 51 sets
only a direction (manual example (0, 0, -1)); :func:`gravity_from_direction` turns it into
``STANDARD_GRAVITY`` (9.81 m/s^2) times the unit direction, so (0, 0, -2) and (0, 0, -1) are the same.

Algorithm: recursive Newton-Euler (outward velocity/acceleration pass, inward force pass) on the URDF
joint frames of ``model.robots`` and the inertial set of ``model.inertials``; base gravity is folded in
as an upward acceleration of the base. Pure Python arithmetic on 3-vectors: ~0.15 ms per call for 7 axes.
:func:`inverse_dynamics_many` is the same recursion on numpy arrays of many states at once (the replay
of a recording computes every sampled state's torques in one call); a test holds the two equal.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .inertials import STANDARD_GRAVITY, get_inertials, torque_constants
from .robots import RobotModel
from .rotations import rpy_to_matrix

Vec = tuple[float, float, float]
Mat = tuple[Vec, Vec, Vec]

#: Default gravity: 9.81 m/s^2 along base -Z (upright mounting, register 51 default (0, 0, -1)).
DEFAULT_GRAVITY: Vec = (0.0, 0.0, -STANDARD_GRAVITY)


def gravity_from_direction(direction: Sequence[float], magnitude: float = STANDARD_GRAVITY) -> np.ndarray:
    """Gravity vector (m/s^2) from a register 51 direction: ``magnitude`` times the unit direction.

    A zero-length or non-finite direction raises ``ValueError``.
    """
    d = np.asarray(direction, dtype=float).reshape(3)
    norm = float(np.linalg.norm(d))
    if not math.isfinite(norm) or norm < 1e-9:
        raise ValueError(f"gravity direction {tuple(d)} has no usable length")
    return d * (float(magnitude) / norm)


@dataclass(frozen=True)
class _Link:
    rot: Mat  # fixed origin rotation (parent -> joint frame before q), rows
    pos: Vec  # origin in the parent frame, m
    mass: float
    com: Vec  # m, link frame
    inertia: Mat  # kg.m^2 about the COM


@lru_cache(maxsize=32)
def _chain(model: RobotModel) -> tuple[_Link, ...]:
    inertials = get_inertials(model)
    if len(inertials.links) != model.dof:
        raise ValueError(f"{inertials.name} has {len(inertials.links)} links, model has {model.dof} joints")
    links = []
    for joint, link in zip(model.joints, inertials.links, strict=True):
        im = link.inertia_matrix
        links.append(_Link(
            rot=tuple(tuple(float(x) for x in row) for row in rpy_to_matrix(*joint.origin_rpy)),  # type: ignore[arg-type]
            pos=(joint.origin_xyz[0] / 1000.0, joint.origin_xyz[1] / 1000.0, joint.origin_xyz[2] / 1000.0),
            mass=link.mass,
            com=(link.com[0] / 1000.0, link.com[1] / 1000.0, link.com[2] / 1000.0),
            inertia=tuple(tuple(float(x) for x in row) for row in im),  # type: ignore[arg-type]
        ))
    return tuple(links)


def _cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _add(*vs: Vec) -> Vec:
    return (sum(v[0] for v in vs), sum(v[1] for v in vs), sum(v[2] for v in vs))


def _mul(m: Mat, v: Vec) -> Vec:
    return (m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
            m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2])


def _tmul(m: Mat, v: Vec) -> Vec:
    """m^T v."""
    return (m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
            m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
            m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2])


def _joint_rot(fixed: Mat, q: float) -> Mat:
    """fixed . Rz(q)."""
    c, s = math.cos(q), math.sin(q)
    return tuple(  # type: ignore[return-value]
        (r[0] * c + r[1] * s, -r[0] * s + r[1] * c, r[2]) for r in fixed
    )


def _vector(x: Sequence[float] | np.ndarray | None, n: int, what: str) -> list[float]:
    if x is None:
        return [0.0] * n
    arr = np.asarray(x, dtype=float).reshape(-1)
    if arr.size < n:
        raise ValueError(f"{what}: expected {n} values, got {arr.size}")
    return [float(v) for v in arr[:n]]


def inverse_dynamics(
    model: RobotModel,
    q: Sequence[float] | np.ndarray,
    qd: Sequence[float] | np.ndarray | None = None,
    qdd: Sequence[float] | np.ndarray | None = None,
    gravity: Sequence[float] | np.ndarray = DEFAULT_GRAVITY,
    payload_mass: float = 0.0,
    payload_com: Sequence[float] = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """Joint torques (N.m, length ``dof``) for joints ``q``, velocities ``qd``, accelerations ``qdd``.

    ``gravity`` is the base-frame gravity vector in m/s^2; the payload is a point mass ``payload_mass``
    (kg) at ``payload_com`` (mm, flange frame). Extra trailing joint values (7 on the wire) are ignored.
    """
    links = _chain(model)
    n = len(links)
    qv = _vector(q, n, "q")
    qdv = _vector(qd, n, "qd")
    qddv = _vector(qdd, n, "qdd")
    g = np.asarray(gravity, dtype=float).reshape(3)
    mp = float(payload_mass)
    if not math.isfinite(mp) or mp < 0.0:
        raise ValueError(f"payload mass must be finite and >= 0, got {payload_mass!r}")
    pc = np.asarray(payload_com, dtype=float).reshape(3) / 1000.0
    cp: Vec = (float(pc[0]), float(pc[1]), float(pc[2]))

    # Outward pass, everything in the current link frame. Gravity enters as base acceleration -g.
    w: Vec = (0.0, 0.0, 0.0)
    wd: Vec = (0.0, 0.0, 0.0)
    a: Vec = (-float(g[0]), -float(g[1]), -float(g[2]))
    rots: list[Mat] = []
    forces: list[Vec] = []
    moments: list[Vec] = []  # about the link frame origin
    for i, link in enumerate(links):
        rot = _joint_rot(link.rot, qv[i])
        rots.append(rot)
        p = link.pos
        a = _tmul(rot, _add(a, _cross(wd, p), _cross(w, _cross(w, p))))
        w_in = _tmul(rot, w)
        wd_in = _tmul(rot, wd)
        w = (w_in[0], w_in[1], w_in[2] + qdv[i])
        # d/dt of the joint rate term expressed in the moving frame: w_in x (qd z)
        wd = (wd_in[0] + w_in[1] * qdv[i], wd_in[1] - w_in[0] * qdv[i], wd_in[2] + qddv[i])
        c = link.com
        ac = _add(a, _cross(wd, c), _cross(w, _cross(w, c)))
        f = (link.mass * ac[0], link.mass * ac[1], link.mass * ac[2])
        iw = _mul(link.inertia, w)
        moment = _add(_mul(link.inertia, wd), _cross(w, iw), _cross(c, f))
        if i == n - 1 and mp > 0.0:
            ap = _add(a, _cross(wd, cp), _cross(w, _cross(w, cp)))
            fp = (mp * ap[0], mp * ap[1], mp * ap[2])
            f = _add(f, fp)
            moment = _add(moment, _cross(cp, fp))
        forces.append(f)
        moments.append(moment)

    # Inward pass: force and moment each link's joint transmits, projected on its z axis.
    tau = np.empty(n)
    f_out: Vec = (0.0, 0.0, 0.0)
    n_out: Vec = (0.0, 0.0, 0.0)
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            rot_next = rots[i + 1]
            f_child = _mul(rot_next, f_out)
            n_child = _add(_mul(rot_next, n_out), _cross(links[i + 1].pos, f_child))
        else:
            f_child = (0.0, 0.0, 0.0)
            n_child = (0.0, 0.0, 0.0)
        f_out = _add(forces[i], f_child)
        n_out = _add(moments[i], n_child)
        tau[i] = n_out[2]
    return tau


def inverse_dynamics_many(
    model: RobotModel,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    gravity: Sequence[float] | np.ndarray = DEFAULT_GRAVITY,
    payload_mass: float = 0.0,
    payload_com: Sequence[float] = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """:func:`inverse_dynamics` of ``N`` states at once: ``q``, ``qd``, ``qdd`` are ``(N, >= dof)``
    arrays (extra columns ignored), one gravity and payload for all; returns ``(N, dof)`` torques."""
    links = _chain(model)
    n = len(links)
    qv, qdv, qddv = (np.asarray(x, dtype=float)[:, :n] for x in (q, qd, qdd))
    rows = len(qv)
    mp = float(payload_mass)
    if not math.isfinite(mp) or mp < 0.0:
        raise ValueError(f"payload mass must be finite and >= 0, got {payload_mass!r}")
    cp = np.asarray(payload_com, dtype=float).reshape(3) / 1000.0
    w = np.zeros((rows, 3))
    wd = np.zeros((rows, 3))
    a = np.broadcast_to(-np.asarray(gravity, dtype=float).reshape(3), (rows, 3))
    rots, forces, moments = [], [], []
    for i, link in enumerate(links):
        fixed = np.array(link.rot)
        c, s = np.cos(qv[:, i]), np.sin(qv[:, i])
        rot = np.empty((rows, 3, 3))  # fixed . Rz(q)
        rot[:, :, 0] = np.outer(c, fixed[:, 0]) + np.outer(s, fixed[:, 1])
        rot[:, :, 1] = np.outer(c, fixed[:, 1]) - np.outer(s, fixed[:, 0])
        rot[:, :, 2] = fixed[:, 2]
        rots.append(rot)
        p = np.array(link.pos)
        a = np.einsum("nji,nj->ni", rot, a + np.cross(wd, p) + np.cross(w, np.cross(w, p)))
        w_in = np.einsum("nji,nj->ni", rot, w)
        wd_in = np.einsum("nji,nj->ni", rot, wd)
        w = w_in.copy()
        w[:, 2] += qdv[:, i]
        wd = np.column_stack((wd_in[:, 0] + w_in[:, 1] * qdv[:, i], wd_in[:, 1] - w_in[:, 0] * qdv[:, i],
                              wd_in[:, 2] + qddv[:, i]))
        com, inertia = np.array(link.com), np.array(link.inertia)
        f = link.mass * (a + np.cross(wd, com) + np.cross(w, np.cross(w, com)))
        moment = wd @ inertia.T + np.cross(w, w @ inertia.T) + np.cross(com, f)
        if i == n - 1 and mp > 0.0:
            fp = mp * (a + np.cross(wd, cp) + np.cross(w, np.cross(w, cp)))
            f = f + fp
            moment = moment + np.cross(cp, fp)
        forces.append(f)
        moments.append(moment)
    tau = np.empty((rows, n))
    f_out = np.zeros((rows, 3))
    n_out = np.zeros((rows, 3))
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            f_child = np.einsum("nij,nj->ni", rots[i + 1], f_out)
            n_child = np.einsum("nij,nj->ni", rots[i + 1], n_out) + np.cross(links[i + 1].pos, f_child)
            f_out, n_out = forces[i] + f_child, moments[i] + n_child
        else:
            f_out, n_out = forces[i], moments[i]
        tau[:, i] = n_out[:, 2]
    return tau


def gravity_torques(
    model: RobotModel,
    q: Sequence[float] | np.ndarray,
    gravity: Sequence[float] | np.ndarray = DEFAULT_GRAVITY,
    payload_mass: float = 0.0,
    payload_com: Sequence[float] = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """Holding torques (N.m) against gravity of the links and the payload; the arm at rest."""
    return inverse_dynamics(model, q, None, None, gravity, payload_mass, payload_com)


def mass_matrix(
    model: RobotModel,
    q: Sequence[float] | np.ndarray,
    payload_mass: float = 0.0,
    payload_com: Sequence[float] = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """Joint-space inertia matrix (dof x dof, kg.m^2), column j = torques for a unit qdd_j, no gravity."""
    n = model.dof
    m = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = 1.0
        m[:, j] = inverse_dynamics(model, q, None, e, (0.0, 0.0, 0.0), payload_mass, payload_com)
    return m


def torques_to_currents(model: RobotModel, torques: Sequence[float] | np.ndarray) -> np.ndarray:
    """Motor currents (A) for joint torques (one state's, or ``(N, dof)``), through the assumed torque
    constants of ``model.inertials``."""
    tau = np.asarray(torques, dtype=float)
    return (tau.reshape(-1) if tau.ndim < 2 else tau)[..., : model.dof] / torque_constants(model)


def joint_friction(model: RobotModel, qd: Sequence[float] | np.ndarray) -> np.ndarray | None:
    """Torques (N.m) a calibrated model adds to the dynamic model's at joint speeds ``qd`` (rad/s):
    ``offset + viscous * qd + coulomb * sign(qd)`` (``model.calibration``), for one state's speeds or
    an ``(N, dof)`` array of them; ``None`` when it adds none
    (the emulator's own constants have no friction)."""
    cal = model.calibration
    if cal is None or (cal.torque_offsets is None and cal.viscous_friction is None
                       and cal.coulomb_friction is None):
        return None
    v = np.asarray(qd, dtype=float)
    v = (v.reshape(-1) if v.ndim < 2 else v)[..., : model.dof]  # (dof,) or (N, dof)
    out = np.zeros(v.shape)
    if cal.torque_offsets is not None:
        out += np.asarray(cal.torque_offsets)
    if cal.viscous_friction is not None:
        out += np.asarray(cal.viscous_friction) * v
    if cal.coulomb_friction is not None:
        out += np.asarray(cal.coulomb_friction) * np.sign(v)
    return out
