"""Motion registers of newer firmware that manual V1.6.0 lacks: relative moves (83) and
velocity control (81, 82; modes 4 and 5 of register 19).

Register 83 (the SDK's relative ``set_position`` / ``set_servo_angle``, on firmware whose register table has
it): the deltas are resolved when the move starts, from where the previous move of the buffer ended. A TCP
delta adds its position to the start's and applies its rotation in the base frame (as register 92's relative
form); a joint delta adds to each joint. With ``FirmwareProfile.inf_unchanged`` a +inf component means
"unchanged", which for a delta is 0. ``only_check_type`` 1-3 queues nothing and answers the check result in
the reply's third byte, as registers 21 and 23 do (0, or the error code the move would raise).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...model import kinematics as kin
from ..applications import velocity
from ..core.commands import JointMove, LineMove
from ..core.controller_protocol import Controller
from ..core.interface import C_JOINT_LIMIT, Binding, CommandError, NotReady, ParameterError, Values
from ..core.poses import resolve_line_target
from ..core.settings import in_range
from . import motion


def _check_speed(speed: float, acc: float, vmax: float, amax: float) -> None:
    if not (in_range(speed, vmax) and speed > 0.0 and in_range(acc, amax) and acc > 0.0):
        raise ParameterError("speed or acceleration outside Table 1.2")


def _unchanged_as_zero(values: Any) -> tuple[float, ...]:
    """A delta of +inf ("unchanged", ``FirmwareProfile.inf_unchanged``) moves nothing."""
    return tuple(0.0 if math.isinf(x) and x > 0 else float(x) for x in values)


def move_relative(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 83: a relative TCP (is_joint_motion 0) or joint (1) move, queued; or only checked
    (``only_check_type`` 1-3, as the common forms of registers 21 and 23 check)."""
    deltas = _unchanged_as_zero(v["deltas"])
    joint = int(v.get("is_joint_motion", 0))
    axis_angle = int(v.get("is_axis_angle", 0))
    check = int(v.get("only_check_type", 0) or 0)
    if joint not in (0, 1) or axis_angle not in (0, 1) or check > 3:
        raise ParameterError("is_joint_motion and is_axis_angle are 0 or 1, only_check_type 0..3")
    m = ctl.model
    radius = float(v.get("radius", -1.0))
    if joint:
        _check_speed(v["speed"], v["acc"], m.max_joint_speed, m.max_joint_acc)
        delta = np.asarray(deltas[: ctl.dof], dtype=float)
        if check:
            q0 = motion.check_start(ctl, check)
            return _checked(ctl, check, q0 + delta, motion.check_joint_path(ctl, q0, q0 + delta))
        ctl.require_motion_allowed()
        if not ctl.executor.active and not kin.within_limits(m, ctl.q + delta):
            raise CommandError(C_JOINT_LIMIT, "relative joint target outside the limits")
        cmd: JointMove | LineMove = JointMove(83, delta, v["speed"], v["acc"], radius=radius, relative=True)
    else:
        _check_speed(v["speed"], v["acc"], m.max_tcp_speed, m.max_tcp_acc)
        cmd = LineMove(83, deltas[:6], v["speed"], v["acc"], radius=radius, relative=True,
                       axis_angle=bool(axis_angle))
        if check:
            q0 = motion.check_start(ctl, check)
            result, end = motion.check_line_path(ctl, q0, resolve_line_target(cmd, ctl.tcp_matrix(q0)))
            return _checked(ctl, check, end, result)
        ctl.require_motion_allowed()
    ctl.queue(cmd)
    return {"cmdnum": ctl.executor.cmdnum, "check_result": 0}


def _checked(ctl: Controller, check: int, end: np.ndarray | None, result: int) -> dict[str, Any]:
    """Keep the intermediate state of an only-check (types 1 and 3: where it ended; type 2: back to
    the actual joints) and reply its result (0, or the error code the move would raise)."""
    ctl.data.check_q = None if check == 2 or end is None else end
    return {"cmdnum": ctl.executor.cmdnum, "check_result": result}


def _duration(ctl: Controller, v: Values) -> float | None:
    d = v.get("duration")
    if d is None or not ctl.firmware.velocity_duration:
        return None
    if d < 0.0:
        raise ParameterError("duration must be >= 0")
    return float(d)


def _require_mode(ctl: Controller, mode: int) -> None:
    if ctl.error_code or not ctl.ready or ctl.mode != mode:
        raise NotReady()


def set_joint_velocity(ctl: Controller, v: Values) -> None:
    """Register 81 (mode 4): joint velocities (rad/s), ``is_sync`` 1 ramps all joints together."""
    speeds = np.asarray(v["speeds"][: ctl.dof], dtype=float)
    sync = int(v["is_sync"])
    if sync not in (0, 1):
        raise ParameterError("is_sync is 0 or 1")
    if np.any(np.abs(speeds) > ctl.model.max_joint_speed * (1 + 1e-6)):
        raise ParameterError("joint speed above the maximum (Table 1.2)")
    duration = _duration(ctl, v)
    _require_mode(ctl, velocity.MODE_JOINT_VELOCITY)
    velocity.command(ctl, velocity.MODE_JOINT_VELOCITY, speeds, sync=bool(sync), duration=duration)
    return None


def set_cartesian_velocity(ctl: Controller, v: Values) -> None:
    """Register 82 (mode 5): TCP velocity (vx, vy, vz mm/s; wx, wy, wz rad/s), base or tool frame."""
    speeds = np.asarray(v["speeds"], dtype=float)
    tool = int(v["is_tool_coord"])
    if tool not in (0, 1):
        raise ParameterError("is_tool_coord is 0 or 1")
    m = ctl.model
    if float(np.linalg.norm(speeds[:3])) > m.max_tcp_speed * (1 + 1e-6) or np.any(
            np.abs(speeds[3:]) > m.max_joint_speed * (1 + 1e-6)):
        raise ParameterError("TCP speed above the maximum (Table 1.2)")
    duration = _duration(ctl, v)
    _require_mode(ctl, velocity.MODE_CARTESIAN_VELOCITY)
    velocity.command(ctl, velocity.MODE_CARTESIAN_VELOCITY, speeds, tool_frame=bool(tool), duration=duration)
    return None


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(81, set_joint_velocity),
    Binding(82, set_cartesian_velocity),
    Binding(83, move_relative),
)
