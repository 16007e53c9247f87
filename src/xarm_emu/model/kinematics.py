"""Forward and inverse kinematics, Jacobian, joint limits, TCP offset and user coordinate offset.

Frames (the vendor URDF's joint origins): each joint is ``Trans(xyz) . R(rpy) . Rz(q)`` on
its parent, the flange (default TCP) is the frame after the last joint, lengths in mm, angles in rad.

Speed: the joint chain of each model is unrolled on first use into straight-line scalar Python code, with
zero offsets and the exact +/-pi/2 origin rotations folded away (the code generator is :mod:`._unroll`;
its functions are cached here per model object). ``joint_frames`` keeps a plain numpy 4x4 chain, which
the tests use as an independent check of the unrolled code.

Inverse kinematics (manual register 43):
- xArm6/xArm7: Levenberg-Marquardt from the seed (the current joints or the SDK's ``ref_angles``), so
  the posture follows the seed; xArm7 takes the minimum-norm step, keeping the elbow near the seed.
  Converged means |dp| <= 1e-6 mm and |d theta| <= 1e-7 rad; otherwise there is no solution (None).
- xArm5: closed form; only targets with the flange level (roll = +/-pi, pitch = 0) are reachable.
- ``limited`` (the SDK's flag, default on): each joint is wrapped into [-pi, pi] when its limits allow,
  else shifted by 2 pi into its limits; any joint outside its limits gives None.

TCP offset (manual 1.5 "TCP Offset", register 35): ``T_tcp = T_flange . Trans(x, y, z) . Rz Ry Rx``.
User coordinate offset (register 73): the six values are the pose of the user coordinate system in the
base coordinate system, so a pose seen in the user frame is ``inv(T_user) . T_tcp``. This is the reading of
the xArm user manual's worked example ("express the position and orientation of user coordinate system {C}
in coordinate system {A}": offset (1000, 0, 0, 0, 0, 180 deg) turns (207, 0, 112, 180, 0, 0) into
(793, 0, 112, 180, 0, 180)); the developer manual's one-line description of register 73 is ambiguous.
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Callable, Sequence

import numpy as np

from ._unroll import generate
from .robots import RobotModel, joint_values
from .rotations import invert_transform, matrix_to_axis_angle, pose_to_matrix

POS_TOL = 1e-6  # mm
ROT_TOL = 1e-7  # rad
MAX_ITER = 60
XARM5_LEVEL_TOL = 1e-6  # allowed tilt of the xArm5 tool axis from vertical (rad, ~float32 noise)
_POS_SCALE = 1e-3  # IK weights position error in metres against rotation in rad
LM_MU = 0.1
MAX_STEP = 0.5  # rad
#: Path following (:func:`track`): chord steps with the stored matrix before it is refreshed, and the
#: farthest (rad, any joint) a tracked answer may lie from the previous joints before the full solve
#: decides instead (a path needs at most pi rad/s * 4 ms = 0.013 rad per period, Table 1.2).
TRACK_CHORDS = 2
TRACK_MAX_MOVE = 0.05

_CACHE: dict[int, tuple[RobotModel, dict[str, Callable[..., tuple[float, ...]]]]] = {}
_LIMITS: dict[int, tuple[RobotModel, tuple[float, ...], tuple[float, ...]]] = {}


def _chain_fn(model: RobotModel, mode: str) -> Callable[..., tuple[float, ...]]:
    entry = _CACHE.get(id(model))
    if entry is None or entry[0] is not model:
        ptol2, rtol2 = (POS_TOL * 1e-3) ** 2, ROT_TOL ** 2  # the LM step works in metres
        fns = {m: generate(model, m, ptol2, rtol2, MAX_STEP, TRACK_MAX_MOVE)
               for m in ("fk", "jac", "lm", "track", "track3")}
        fns["fk_arrays"] = generate(model, "fk", ptol2, rtol2, MAX_STEP, arrays=True)
        entry = _CACHE[id(model)] = (model, fns)
    return entry[1][mode]


def _limits(model: RobotModel) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Lower and upper joint limits of ``model`` as tuples of floats (cached per model object)."""
    entry = _LIMITS.get(id(model))
    if entry is None or entry[0] is not model:
        lo = tuple(float(j.lower) for j in model.joints)
        hi = tuple(float(j.upper) for j in model.joints)
        entry = _LIMITS[id(model)] = (model, lo, hi)
    return entry[1], entry[2]


# --------------------------------------------------------------------------------------------------------
# Forward kinematics, frames, Jacobian


def fk(model: RobotModel, q: Sequence[float] | np.ndarray) -> np.ndarray:
    """4x4 flange pose in the base frame (mm). Extra joint values (wire J7 on xArm6) are ignored."""
    r = _chain_fn(model, "fk")(*joint_values(model, q))
    return np.array(
        ((r[0], r[1], r[2], r[9]), (r[3], r[4], r[5], r[10]), (r[6], r[7], r[8], r[11]), (0.0, 0.0, 0.0, 1.0))
    )


def joint_frames(model: RobotModel, q: Sequence[float] | np.ndarray) -> list[np.ndarray]:
    """4x4 frame of each joint (after its rotation, i.e. the URDF link frame) in the base frame.

    The last one is the flange. Plain numpy chain, independent of the unrolled ``fk``.
    """
    qs = joint_values(model, q)
    T = np.eye(4)
    frames = []
    for j, qi in zip(model.joints, qs, strict=True):
        T = T @ pose_to_matrix((*j.origin_xyz, *j.origin_rpy)) @ pose_to_matrix((0, 0, 0, 0, 0, qi))
        frames.append(T)
    return frames


def jacobian(model: RobotModel, q: Sequence[float] | np.ndarray) -> np.ndarray:
    """Geometric Jacobian (6 x dof) of the flange in the base frame: rows vx, vy, vz (mm/rad), wx, wy, wz."""
    r = _chain_fn(model, "jac")(*joint_values(model, q))
    return np.array(r[12:]).reshape(6, model.dof)


def tcp_speed(model: RobotModel, q: Sequence[float] | np.ndarray, qd: Sequence[float] | np.ndarray,
              tcp_offset: Sequence[float] = (0.0,) * 6) -> float:
    """The TCP's linear speed (mm/s) at joints ``q`` (rad) moving at ``qd`` (rad/s): the flange's
    velocity from the Jacobian plus the angular velocity crossed with the TCP offset (mm, rad)."""
    J = jacobian(model, q)
    w = J @ np.asarray(joint_values(model, qd), dtype=float)
    r = fk(model, q)[:3, :3] @ np.asarray(tcp_offset[:3], dtype=float)
    return float(np.linalg.norm(w[:3] + np.cross(w[3:], r)))


def within_limits(model: RobotModel, q: Sequence[float] | np.ndarray) -> bool:
    """True when every joint is finite and inside its limits (manual 1.3; register 45)."""
    try:
        qs = joint_values(model, q)
    except (ValueError, TypeError):
        return False
    lo, hi = _limits(model)
    return all(map(operator.le, lo, qs)) and all(map(operator.le, qs, hi))


# --------------------------------------------------------------------------------------------------------
# Inverse kinematics


def _lm(model: RobotModel, target: list[list[float]], seed: list[float]) -> list[float] | None:
    """Levenberg-Marquardt on the flange pose, minimum-norm step dq = J^T (J J^T + lambda I)^-1 e.

    The error is weighted (position in metres, rotation in rad); lambda = mu |e|^2 + 1e-12 with mu raised
    tenfold whenever the error grows; a step is capped at MAX_STEP rad on any joint and every iterate is
    clamped into the joint limits (a limit-violating solution would be rejected anyway).
    """
    solve_fn = _chain_fn(model, "lm")
    t = [*target[0][:3], *target[1][:3], *target[2][:3]]
    tp = (target[0][3] * 1e-3, target[1][3] * 1e-3, target[2][3] * 1e-3)
    lo, hi = _limits(model)
    if len(seed) != len(lo):
        raise ValueError(f"{model.name} needs {len(lo)} joint values, got {len(seed)}")
    q = map(min, map(max, seed, lo), hi)  # max(v, lower), then min(., upper), per joint
    try:
        r = solve_fn(*q, *t, *tp, LM_MU, MAX_ITER)  # the whole loop, unrolled per model (._unroll)
    except ValueError:  # Cholesky of a matrix that is not positive definite (degenerate input)
        return None
    return list(r[1:]) if len(r) > 1 else None


def step_matrix(model: RobotModel, q: Sequence[float]) -> tuple[float, ...]:
    """The Newton step matrix M = J^T (J J^T + 1e-12 I)^-1 (dof x 6, row-major) of the flange at ``q``
    (J with its position rows in metres, as the LM weighs the error), for :func:`track`."""
    r = _chain_fn(model, "jac")(*q)
    J = np.array(r[12:]).reshape(6, model.dof)
    J[:3] *= 1e-3
    A = J @ J.T
    A.flat[::7] += 1e-12
    return tuple(np.linalg.solve(A, J).T.ravel().tolist())


def track(
    model: RobotModel,
    T_target: np.ndarray,
    start: Sequence[float],
    matrix: tuple[float, ...] | None,
    previous: Sequence[float],
    fallbacks: Callable[[], Sequence[Sequence[float]]] = tuple,
) -> tuple[tuple[float, ...] | None, tuple[float, ...] | None]:
    """Path following: joints (floats) that put the flange at ``T_target`` from a predicted ``start``,
    and the step matrix to keep for the next period; ``(None, None)`` when there is no solution.

    A chord (simplified Newton) solve: the same FK test as :func:`ik` (|dp| <= POS_TOL, |d theta| <=
    ROT_TOL), then up to :data:`TRACK_CHORDS` steps dq = M e with the stored ``matrix`` M
    (:func:`step_matrix`, kept from an earlier period; None: none yet), each capped at MAX_STEP and
    clamped into the joint limits as the LM's steps, each followed by the test. When they do not converge,
    M is refreshed at the current iterate and the chord solve runs once more (a full Newton step first).
    An answer is taken only if no joint lies farther than :data:`TRACK_MAX_MOVE` from ``previous`` (the
    last joints); otherwise, or without convergence, the full solve (``ik(..., limited=False)``) from each
    of the seeds ``fallbacks()`` gives (computed only then) and then from ``previous`` decides, and no
    matrix is kept. ``start`` and ``previous`` are ``dof`` finite floats, ``previous`` inside the limits
    (``start`` is clamped into them); a target with NaN or inf has no answer (every solve fails); xArm5
    (closed form) has no chord solve.
    """
    if model.dof == 6 and not model.fixed_roll_pitch:
        return _chords(model, T_target, T_target.tolist(), start, matrix, previous, fallbacks, 2)
    return _full_solve(model, T_target, previous, fallbacks)


def _chords(model: RobotModel, T_target: np.ndarray, rows: list[list[float]], q: Sequence[float],
            matrix: tuple[float, ...] | None, previous: Sequence[float],
            fallbacks: Callable[[], Sequence[Sequence[float]]], rounds: int,
            ) -> tuple[tuple[float, ...] | None, tuple[float, ...] | None]:
    """Up to ``rounds`` chord solves of :func:`track` from ``q`` (the matrix refreshed at the
    iterate before each after the first, or before the first when ``matrix`` is None), then the
    full solve."""
    fn = _chain_fn(model, "track")
    for _ in range(rounds):
        try:
            if matrix is None:
                matrix = step_matrix(model, q)
            r = fn(q, rows, matrix, TRACK_CHORDS, previous)
        except (ValueError, TypeError):  # not a 4x4 of numbers, or NaN reached the step matrix
            break
        if len(r) == len(q):
            return r, matrix
        if not r:
            break  # converged too far from the previous joints: the full solve decides
        q = r[:-1]
        matrix = None  # refresh at the current iterate
    return _full_solve(model, T_target, previous, fallbacks)


def _full_solve(model: RobotModel, T_target: np.ndarray, previous: Sequence[float],
                fallbacks: Callable[[], Sequence[Sequence[float]]],
                ) -> tuple[tuple[float, ...] | None, tuple[float, ...] | None]:
    """:func:`ik` from each seed of ``fallbacks()``, then from ``previous``; no matrix kept."""
    for seed in (*fallbacks(), previous):
        sol = ik(model, T_target, seed, limited=False)
        if sol is not None:
            return tuple(sol.tolist()), None
    return None, None


def track_steady(
    model: RobotModel,
    T_target: np.ndarray,
    h: Sequence[Sequence[float]],
    matrix: tuple[float, ...],
    fallbacks: Callable[[], Sequence[Sequence[float]]] = tuple,
) -> tuple[tuple[float, ...] | None, tuple[float, ...] | None]:
    """:func:`track` from the third-order extrapolation over equal path-time steps of the last four
    answers ``h`` (oldest first): ``track(model, T_target, start, matrix, h[3], fallbacks)`` with
    ``start`` = 4 (h3 + h1) - 6 h2 - h0 per joint, the same answer bit for bit, in one call of the
    generated code (the start computed there). Only for a 6-axis arm other than the xArm5, with a
    stored ``matrix``."""
    fn = _chain_fn(model, "track3")
    rows = T_target.tolist()
    anchor = h[3]
    try:
        r = fn(h[0], h[1], h[2], anchor, rows, matrix, TRACK_CHORDS)
    except (ValueError, TypeError):  # not a 4x4 of numbers, or NaN reached the step
        r = ()
    if len(r) == len(anchor):
        return r, matrix
    if r:  # not converged: refresh the matrix at the last iterate, the chord solve once more
        return _chords(model, T_target, rows, r[:-1], None, anchor, fallbacks, 1)
    return _full_solve(model, T_target, anchor, fallbacks)


def _fit_limits(model: RobotModel, q: list[float], limited: bool) -> np.ndarray | None:
    """Wrap into [-pi, pi] where the limits allow (limited), else shift by 2 pi into the limits."""
    if not limited:
        lo, hi = _limits(model)
        if all(map(operator.le, lo, q)) and all(map(operator.le, q, hi)):
            return np.array(q)  # every joint already inside its limits (the usual case)
    out = []
    two_pi = 2.0 * math.pi
    for j, v in zip(model.joints, q, strict=True):
        w = math.remainder(v, two_pi) if limited else v  # remainder: [-pi, pi]
        if j.lower <= w <= j.upper:
            out.append(w)
        elif j.lower <= w - two_pi <= j.upper:
            out.append(w - two_pi)
        elif j.lower <= w + two_pi <= j.upper:
            out.append(w + two_pi)
        else:
            return None
    return np.array(out)


def _ik_xarm5(model: RobotModel, target: np.ndarray, seed: list[float], limited: bool) -> np.ndarray | None:
    """Closed form for a 5-axis arm whose tool stays vertical."""
    R = target[:3, :3]
    tol = XARM5_LEVEL_TOL
    if not (R[2, 2] < 0.0 and abs(R[0, 2]) < tol and abs(R[1, 2]) < tol and abs(R[2, 0]) < tol
            and abs(R[2, 1]) < tol):
        return None
    yaw = math.atan2(R[1, 0], R[0, 0])
    x, y, z = (float(v) for v in target[:3, 3])
    j = model.joints
    base_z = j[0].origin_xyz[2]
    u1 = (j[2].origin_xyz[0], -j[2].origin_xyz[1])  # upper arm in the arm plane (forward, up)
    u2 = (j[3].origin_xyz[0], -j[3].origin_xyz[1])  # forearm
    u3 = (j[4].origin_xyz[0], -j[4].origin_xyz[1])  # wrist to flange
    l1, l2 = math.hypot(*u1), math.hypot(*u2)
    a1, a2 = math.atan2(u1[1], u1[0]), math.atan2(u2[1], u2[0])
    best: tuple[float, np.ndarray] | None = None
    radial = math.hypot(x, y)
    heading = math.atan2(y, x) if radial > 1e-9 else seed[0]
    for q1, r in ((heading, radial), (heading + math.pi, -radial)):
        dx, dz = r - u3[0], z - u3[1] - base_z
        c = (dx * dx + dz * dz - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
        if c > 1.0 + 1e-12 or c < -1.0 - 1e-12:
            continue
        c = max(-1.0, min(1.0, c))
        for delta in (-math.acos(c), math.acos(c)):
            phi1 = math.atan2(dz, dx) - math.atan2(l2 * math.sin(delta), l1 + l2 * math.cos(delta))
            q2 = a1 - phi1
            q3 = a2 - a1 - delta
            q = [q1, math.remainder(q2, 2 * math.pi), math.remainder(q3, 2 * math.pi), 0.0, 0.0]
            q[3] = -(q[1] + q[2])
            q[4] = q1 - yaw
            # nearest 2 pi multiples of J1/J5 to the seed before limits are applied
            for k in (0, 4):
                q[k] = seed[k] + math.remainder(q[k] - seed[k], 2.0 * math.pi)
            q[3] = math.remainder(q[3], 2.0 * math.pi)
            sol = _fit_limits(model, q, limited)
            if sol is None:
                continue
            dist = float(np.sum((sol - np.array(seed)) ** 2))
            if best is None or dist < best[0]:
                best = (dist, sol)
    return None if best is None else best[1]


def _residual_ok(model: RobotModel, q: np.ndarray, target: np.ndarray) -> bool:
    T = fk(model, q)
    perr = float(np.linalg.norm(T[:3, 3] - target[:3, 3]))
    rerr = float(np.linalg.norm(matrix_to_axis_angle(target[:3, :3] @ T[:3, :3].T)))
    return perr <= 10 * POS_TOL and rerr <= 10 * ROT_TOL


#: Extra starting points tried by ``ik(..., restarts=True)`` after the seed itself fails: fractions of
#: each joint's range, fixed so that results are deterministic.
_RESTART_FRACTIONS = (
    (0.5, 0.45, 0.55, 0.5, 0.6, 0.5, 0.5),
    (0.5, 0.6, 0.35, 0.5, 0.7, 0.5, 0.5),
    (0.5, 0.35, 0.7, 0.5, 0.4, 0.5, 0.5),
    (0.5, 0.5, 0.45, 0.6, 0.55, 0.4, 0.5),
)


def ik(
    model: RobotModel,
    T_target: np.ndarray,
    seed: Sequence[float] | np.ndarray | None = None,
    limited: bool = True,
    restarts: bool = False,
) -> np.ndarray | None:
    """Joints (length dof) that put the flange at ``T_target`` (4x4, base frame, mm), or None.

    ``seed`` defaults to zero joints. Never raises on bad numbers: NaN/inf input gives None.
    For path following pass ``limited=False`` so that joints stay continuous with the seed.
    With ``restarts`` (targets of moves, register 43), a seed that does not converge is followed by
    the seed turned toward the target about J1, then fixed starting points; the answer nearest the
    seed wins. Path following keeps ``restarts`` off so that the posture follows the seed.
    """
    sol = _ik_once(model, T_target, seed, limited)
    if sol is not None or not restarts or model.fixed_roll_pitch:
        return sol
    try:
        target = np.asarray(T_target, dtype=float)
        base = np.zeros(model.dof) if seed is None else np.asarray(joint_values(model, seed), dtype=float)
        heading = math.atan2(float(target[1, 3]), float(target[0, 3]))
    except (ValueError, TypeError, IndexError):
        return None
    if not (np.all(np.isfinite(base)) and math.isfinite(heading)):
        return None
    lo, hi = model.lower, model.upper
    starts = [np.concatenate(([heading], base[1:]))]
    for frac in _RESTART_FRACTIONS:
        q0 = lo + np.asarray(frac[: model.dof]) * (hi - lo)
        q0[0] = heading
        starts.append(q0)
    best: tuple[float, np.ndarray] | None = None
    for q0 in starts:
        cand = _ik_once(model, target, q0, limited)
        if cand is None:
            continue
        dist = float(np.sum((cand - base) ** 2))
        if best is None or dist < best[0]:
            best = (dist, cand)
    return None if best is None else best[1]


def _ik_once(
    model: RobotModel,
    T_target: np.ndarray,
    seed: Sequence[float] | np.ndarray | None,
    limited: bool,
) -> np.ndarray | None:
    """One seeded solve (see :func:`ik`)."""
    try:
        target = np.asarray(T_target, dtype=float)
        if target.shape != (4, 4):
            return None
        rows = target.tolist()
        if not math.isfinite(sum(map(sum, rows))):  # NaN or inf anywhere
            return None
        qs = [0.0] * model.dof if seed is None else joint_values(model, seed)
    except (ValueError, TypeError, OverflowError):
        return None
    if model.fixed_roll_pitch:
        sol = _ik_xarm5(model, target, qs, limited)
        if sol is not None and not _residual_ok(model, sol, target):
            return None
        return sol
    raw = _lm(model, rows, qs)  # converged to POS_TOL / ROT_TOL, or None
    return None if raw is None else _fit_limits(model, raw, limited)


# --------------------------------------------------------------------------------------------------------
# TCP offset (register 35) and user coordinate offset (register 73)


def tcp_pose(
    model: RobotModel,
    q: Sequence[float] | np.ndarray,
    tcp_offset: Sequence[float] = (0.0,) * 6,
    user_offset: Sequence[float] = (0.0,) * 6,
) -> np.ndarray:
    """4x4 pose of the TCP in the user frame: inv(T_user) . T_flange(q) . T_tcp (module docstring)."""
    T = fk(model, q) @ pose_to_matrix(tcp_offset)
    if any(user_offset):
        T = invert_transform(pose_to_matrix(user_offset)) @ T
    return T


def tcp_positions(
    model: RobotModel,
    q: np.ndarray,
    tcp_offset: Sequence[float] = (0.0,) * 6,
    user_offset: Sequence[float] = (0.0,) * 6,
) -> np.ndarray:
    """The TCP positions (mm, ``(N, 3)``) of :func:`tcp_pose` for ``N`` joint states at once
    (``q`` of shape ``(N, >= dof)``, extra columns ignored), one TCP and user offset for all."""
    qs = np.asarray(q, dtype=float)
    r = _chain_fn(model, "fk_arrays")(*(qs[:, i] for i in range(model.dof)))
    rows = len(qs)
    R = np.stack([np.broadcast_to(np.asarray(x, dtype=float), (rows,)) for x in r[:9]], axis=1)
    p = np.stack([np.broadcast_to(np.asarray(x, dtype=float), (rows,)) for x in r[9:12]], axis=1)
    pos = p + R.reshape(rows, 3, 3) @ np.asarray(tcp_offset[:3], dtype=float)
    if any(user_offset):
        inv = invert_transform(pose_to_matrix(user_offset))
        pos = pos @ inv[:3, :3].T + inv[:3, 3]
    return pos


def flange_target(
    T_tcp_in_user: np.ndarray,
    tcp_offset: Sequence[float] = (0.0,) * 6,
    user_offset: Sequence[float] = (0.0,) * 6,
) -> np.ndarray:
    """4x4 flange pose in the base frame that puts the TCP at ``T_tcp_in_user`` (inverse of tcp_pose)."""
    T = np.asarray(T_tcp_in_user, dtype=float)
    if any(user_offset):
        T = _offset_matrix(tuple(map(float, user_offset))) @ T
    if any(tcp_offset):
        T = T @ _inverse_offset(tuple(map(float, tcp_offset)))
    return T


@functools.lru_cache(maxsize=32)
def _offset_matrix(offset: tuple[float, ...]) -> np.ndarray:
    """``pose_to_matrix(offset)``, once for each offset (asked every control period of a move);
    read-only."""
    T = pose_to_matrix(offset)
    T.flags.writeable = False
    return T


@functools.lru_cache(maxsize=32)
def _inverse_offset(offset: tuple[float, ...]) -> np.ndarray:
    """The inverse of ``pose_to_matrix(offset)``, once for each offset; read-only."""
    T = invert_transform(pose_to_matrix(offset))
    T.flags.writeable = False
    return T


def pose_offset(T1: np.ndarray, T2: np.ndarray) -> np.ndarray:
    """4x4 offset from pose 1 to pose 2 as register 76 reports it: translation p2 - p1 in the base frame,
    rotation R2 . R1^T (manual register 76 example: z 200 -> 100 gives z = -100)."""
    D = np.eye(4)
    D[:3, :3] = T2[:3, :3] @ T1[:3, :3].T
    D[:3, 3] = T2[:3, 3] - T1[:3, 3]
    return D
