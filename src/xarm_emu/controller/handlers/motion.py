"""Motion commands (manual section 2.1.3, registers 21-30, 92 and 93): queued moves and servo targets.

Firmware with the profile's ``common_move_layout`` takes the "common" forms the SDK
sends: register 21 with blend radius, coordinate frame, axis-angle flag, only-check byte and motion
type; 27 with the frame, axis-angle and only-check bytes; 23, 24 and 25 with an only-check byte.
Their replies carry a third byte, the check result. An only-check command (types 1-3, as the
SDK documents them) moves nothing and is not queued: it checks the path from the actual joints
(type 1) or from where the previous check ended (types 2 and 3) and replies 0, or the error code the
move would raise (C21, C22, C23, C35). Joint moves are checked along their straight joint path; linear
moves along their TCP line; a circle along lines through its two points. The common form's motion
type byte chooses the planning of register 21: 0 a TCP line, 1 a TCP line or, where the line leaves
the reachable joints, a joint move, 2 a joint move to the pose.
With the profile's ``inf_unchanged``, +inf in a pose or joint value of 21 or 23 keeps that component
where it is when the move starts.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from ...model import collision
from ...model import kinematics as kin
from ...model import rotations as rot
from .. import motion
from ..applications import online
from ..core import safety
from ..core.commands import CircleMove, Dwell, JointMove, LineMove
from ..core.controller_protocol import Controller
from ..core.executor import keep_unchanged_joints, line_target
from ..core.interface import (
    C_BOUNDARY,
    C_JOINT_LIMIT,
    C_KINEMATIC,
    C_SELF_COLLISION,
    WARN_NO_SOLUTION,
    Binding,
    CommandError,
    CommandWarning,
    ParameterError,
    Values,
)
from ..core.poses import apply_offset, wire_pose_to_matrix
from ..core.settings import in_range
from .settings import report_tau_or_i

#: Joint positions sampled along the straight joint path of an only-check move.
CHECK_SAMPLES = 24


def check_speed(speed: float, acc: float, vmax: float, amax: float) -> None:
    """Speed and acceleration above 0 and within Table 1.2 (section 1.3), else warning 12."""
    if not (in_range(speed, vmax) and speed > 0.0 and in_range(acc, amax) and acc > 0.0):
        raise ParameterError("speed or acceleration outside Table 1.2")


def _reply(ctl: Controller, check_result: int = 0) -> dict[str, Any]:
    """Reply of a queued move: the buffer count, and for the common forms the check result."""
    return {"cmdnum": ctl.executor.cmdnum, "check_result": check_result}


def _check_type(v: Values) -> int:
    """The only-check byte: 0 move; 1 check from the actual joints; 2 and 3 from the intermediate
    state the previous check left (2 then returns it to the actual joints)."""
    t = int(v.get("only_check_type", 0))
    if t > 3:
        raise ParameterError("only-check type is 0..3")
    return t


def check_start(ctl: Controller, check: int) -> np.ndarray:
    """The joints an only-check path starts from: the actual ones (type 1) or the intermediate state."""
    kept = ctl.data.check_q
    return ctl.q.copy() if check == 1 or kept is None else kept.copy()


def _checked(ctl: Controller, check: int, end: np.ndarray | None, result: int) -> dict[str, Any]:
    """Keep the intermediate state after an only-check (types 1 and 3: the end of the path; type 2:
    back to the actual joints) and reply the result."""
    ctl.data.check_q = None if check == 2 or end is None else end
    return _reply(ctl, result)


def check_joint_path(ctl: Controller, q0: np.ndarray, target: np.ndarray) -> int:
    """Only-check joint moves: 0 when the straight joint path from ``q0`` to ``target`` stays within
    the joint limits and free of self-collision, else the error code the move would raise (C23, C22)."""
    if not (np.all(np.isfinite(target)) and kin.within_limits(ctl.model, target)):
        return C_JOINT_LIMIT
    for s in np.linspace(0.0, 1.0, CHECK_SAMPLES):
        if _collides(ctl, q0 + s * (target - q0)):
            return C_SELF_COLLISION
    return 0


def check_line_path(ctl: Controller, q0: np.ndarray, target: np.ndarray) -> tuple[int, np.ndarray | None]:
    """Only-check linear moves: the straight TCP line from joints ``q0`` to the pose ``target``,
    sampled. Returns 0 or the error code the move would raise (C21 no inverse kinematics, C23 joint
    limit, C22 self-collision, C35 safety boundary), and the joints where the check ended."""
    path = motion.LinePath(ctl.tcp_matrix(q0), target)
    seed = q0
    s = ctl.settings
    for u in np.linspace(0.0, 1.0, CHECK_SAMPLES):
        pose = path.pose_u(float(u))
        q = kin.ik(ctl.model, ctl.flange_target(pose), seed, limited=False)
        if q is None:
            return C_KINEMATIC, None
        seed = np.asarray(q, dtype=float)
        if not kin.within_limits(ctl.model, seed):
            return C_JOINT_LIMIT, seed
        if _collides(ctl, seed):
            return C_SELF_COLLISION, seed
        if safety.boundary_violation(tuple(pose[:3, 3]), s.boundary, s.boundary_on):
            return C_BOUNDARY, seed
    return 0, seed


def _collides(ctl: Controller, q: np.ndarray) -> bool:
    hit, _, _ = collision.self_collision(ctl.model, q, ctl.collision_tool)
    return hit


def move_line(ctl: Controller, v: Values, *, register: int) -> dict[str, Any]:
    """Registers 21 (linear), 22 (with arc blending) and 28 (tool frame, relative); 21 also in the
    common form (frame, axis-angle, only-check, motion type)."""
    check_speed(v["speed"], v["acc"], ctl.model.max_tcp_speed, ctl.model.max_tcp_acc)
    tool = register == 28
    axis_angle = False
    if "coord" in v:
        if v["coord"] not in (0, 1) or v["is_axis_angle"] not in (0, 1):
            raise ParameterError("coordinate and axis-angle flags are 0 or 1")
        tool, axis_angle = v["coord"] == 1, v["is_axis_angle"] == 1
    motion_type = int(v.get("motion_type", 0))
    if motion_type not in (0, 1, 2):
        raise ParameterError("motion type is 0, 1 or 2")
    cmd = LineMove(register, tuple(v["pose"]), v["speed"], v["acc"], radius=float(v.get("radius", -1.0)),
                   tool_frame=tool, relative=tool, axis_angle=axis_angle, motion_type=motion_type)
    check = _check_type(v)
    if check:
        q0 = check_start(ctl, check)
        target = line_target(cmd, ctl.tcp_matrix(q0))
        if motion_type == 2:
            q = kin.ik(ctl.model, ctl.flange_target(target), q0, limited=False, restarts=True)
            if q is None:
                return _checked(ctl, check, None, C_KINEMATIC)
            q_end = np.asarray(q, dtype=float)
            return _checked(ctl, check, q_end, check_joint_path(ctl, q0, q_end))
        result, end = check_line_path(ctl, q0, target)
        return _checked(ctl, check, end, result)
    ctl.require_motion_allowed()
    ctl.queue(cmd)
    return _reply(ctl)


def move_line_aa(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 92: linear motion with an axis-angle pose, base or tool frame, absolute or relative."""
    check_speed(v["speed"], v["acc"], ctl.model.max_tcp_speed, ctl.model.max_tcp_acc)
    if v["coord"] not in (0, 1) or v["relative"] not in (0, 1):
        raise ParameterError("coordinate and relative flags are 0 or 1")
    ctl.require_motion_allowed()
    cmd = LineMove(92, tuple(v["pose"]), v["speed"], v["acc"], tool_frame=bool(v["coord"]),
                   relative=bool(v["relative"]) or bool(v["coord"]), axis_angle=True)
    ctl.queue(cmd)
    return _reply(ctl)


def joint_target(ctl: Controller, joints: tuple[float, ...]) -> np.ndarray:
    """The joint target of a move; outside the limits is error C23. +inf values (joints kept, where
    the profile lets +inf through) stay in the target until the move starts; only the given values
    are checked here."""
    q = np.asarray(joints[: ctl.dof], dtype=float)
    if not kin.within_limits(ctl.model, keep_unchanged_joints(q, ctl.q)):
        raise CommandError(C_JOINT_LIMIT, "joint target outside the limits")
    return q


def move_joint(ctl: Controller, v: Values, *, register: int) -> dict[str, Any]:
    """Register 23 (P2P joint motion) and register 24's joint form (a blend radius); both with the
    common forms' only-check byte."""
    check_speed(v["speed"], v["acc"], ctl.model.max_joint_speed, ctl.model.max_joint_acc)
    check = _check_type(v)
    if check:
        q0 = check_start(ctl, check)
        q = keep_unchanged_joints(np.asarray(v["joints"][: ctl.dof], dtype=float), q0)
        return _checked(ctl, check, q, check_joint_path(ctl, q0, q))
    ctl.require_motion_allowed()
    q = joint_target(ctl, v["joints"])
    ctl.queue(JointMove(register, q, v["speed"], v["acc"], radius=float(v.get("radius", -1.0))))
    return _reply(ctl)


def register_24(ctl: Controller, v: Values) -> dict[str, Any] | None:
    """Register 24: the manual's form selects torque or current in reports (1 byte); SDKs for
    newer firmware (register 24's row of the register table) send a joint move with a blend radius
    here (10 fp32, then the only-check byte with ``common_move_layout``)."""
    if "joints" in v:
        return move_joint(ctl, v, register=24)
    report_tau_or_i(ctl, v)
    return None


def move_home(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 25: joint move to the zero position."""
    check_speed(v["speed"], v["acc"], ctl.model.max_joint_speed, ctl.model.max_joint_acc)
    home = np.zeros(ctl.dof)
    check = _check_type(v)
    if check:
        q0 = check_start(ctl, check)
        return _checked(ctl, check, home, check_joint_path(ctl, q0, home))
    ctl.require_motion_allowed()
    ctl.queue(JointMove(25, home, v["speed"], v["acc"]))
    return _reply(ctl)


def dwell(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 26: pause the command queue."""
    t = v["seconds"]
    if not (math.isfinite(t) and t >= 0.0):
        raise ParameterError("pause time must be >= 0")
    ctl.require_motion_allowed()
    ctl.queue(Dwell(26, t))
    return _reply(ctl)


def move_circle(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 27: circle through the current point, pose1 and pose2 (64 bytes, or 67 with the
    frame, axis-angle and only-check bytes)."""
    check_speed(v["speed"], v["acc"], ctl.model.max_tcp_speed, ctl.model.max_tcp_acc)
    if v["percent"] <= 0.0:
        raise ParameterError("percent must be > 0")
    pose1, pose2 = tuple(v["pose1"]), tuple(v["pose2"])
    if "coord" in v:
        if v["coord"] not in (0, 1) or v["is_axis_angle"] not in (0, 1):
            raise ParameterError("coordinate and axis-angle flags are 0 or 1")
        tool, axis_angle = v["coord"] == 1, v["is_axis_angle"] == 1
        pose1, pose2 = (_as_base_rpy(ctl, p, tool, axis_angle) for p in (pose1, pose2))
    check = _check_type(v)
    if check:
        end: np.ndarray | None = check_start(ctl, check)
        result = 0
        for pose in (pose1, pose2):  # the circle's points, each reached by a checked line
            assert end is not None
            result, end = check_line_path(ctl, end, wire_pose_to_matrix(pose))
            if result:
                break
        return _checked(ctl, check, end, result)
    ctl.require_motion_allowed()
    ctl.queue(CircleMove(27, pose1, pose2, v["speed"], v["acc"], v["percent"]))
    return _reply(ctl)


def _as_base_rpy(ctl: Controller, pose: tuple[float, ...], tool: bool, axis_angle: bool) -> tuple[float, ...]:
    """A circle pose of the common form as a base-frame RPY pose: a tool-frame pose is taken from the
    TCP pose when the command arrives (not where the queue leaves the arm), axis-angle orientations
    are converted."""
    if not (tool or axis_angle):
        return pose
    to_matrix = rot.pose_aa_to_matrix if axis_angle else wire_pose_to_matrix
    T = apply_offset(ctl.tcp_matrix(), to_matrix(np.asarray(pose, dtype=float)), tool, False)
    return tuple(float(x) for x in rot.matrix_to_pose(T))


def servoj(ctl: Controller, v: Values) -> None:
    """Register 29: servo joint target (mode 1)."""
    ctl.require_motion_allowed(servo=True)
    ctl.servo_target = joint_target(ctl, v["joints"])
    return None


def _servo_cartesian(ctl: Controller, T: np.ndarray) -> None:
    q = kin.ik(ctl.model, ctl.flange_target(T), ctl.q, limited=False)
    if q is None:
        raise CommandWarning(WARN_NO_SOLUTION)
    if not kin.within_limits(ctl.model, q):
        raise CommandError(C_JOINT_LIMIT)
    ctl.servo_target = q


def servo_cartesian(ctl: Controller, v: Values) -> None:
    """Register 30: servo Cartesian target (mode 1), base or tool frame."""
    ctl.require_motion_allowed(servo=True)
    delta = wire_pose_to_matrix(v["pose"])
    _servo_cartesian(ctl, apply_offset(ctl.tcp_matrix(), delta, v["coord"] != 0.0, False))
    return None


def servo_cartesian_aa(ctl: Controller, v: Values) -> None:
    """Register 93: servo Cartesian target with an axis-angle pose (mode 1)."""
    ctl.require_motion_allowed(servo=True)
    delta = rot.pose_aa_to_matrix(np.asarray(v["pose"], dtype=float))
    T = apply_offset(ctl.tcp_matrix(), delta, v["coord"] != 0.0, int(v.get("relative", 0)) == 1)
    _servo_cartesian(ctl, T)
    return None


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    # In online planning (modes 6/7, firmware 2.x) a joint or linear move is a new online target.
    Binding(21, functools.partial(move_line, register=21),
            mode_route={online.MODE_CARTESIAN_ONLINE: online.cartesian_target}),
    Binding(22, functools.partial(move_line, register=22)),
    Binding(23, functools.partial(move_joint, register=23),
            mode_route={online.MODE_JOINT_ONLINE: online.joint_target}),
    Binding(24, register_24, mode_route={online.MODE_JOINT_ONLINE: online.joint_target}),
    Binding(25, move_home),
    Binding(26, dwell),
    Binding(27, move_circle),
    Binding(28, functools.partial(move_line, register=28)),
    Binding(29, servoj),
    Binding(30, servo_cartesian),
    Binding(92, move_line_aa),
    Binding(93, servo_cartesian_aa),
)
