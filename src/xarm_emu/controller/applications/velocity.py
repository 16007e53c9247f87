"""Velocity control: joint velocity (mode 4, register 81) and Cartesian velocity (mode 5, register 82).

The SDK sends the commanded velocity and, for firmware with ``FirmwareProfile.velocity_duration``, a duration
in seconds: above 0 the velocity returns to zero once the duration has run out; 0 (or no duration) keeps it
until the next command. Each control period the arm's velocity heads for the commanded one along a
jerk-limited ramp (ruckig's offline planner from the present velocity and acceleration, velocity interface;
the joint jerk and maximum acceleration of registers 33/34, or the TCP ones of 31/32), so once the ramp is
over the arm moves at exactly the commanded velocity.

Limits: joint speeds are clipped to the model's maximum (manual 1.3, Table 1.2), TCP speeds to the
maximum TCP speed, or to the reduced-mode maxima (registers 47/48) while reduced mode is on. A joint
heading for its limit slows down so that it stops on the limit and stays there (it does not
raise an error: the other joints keep their velocities); a Cartesian velocity that would leave
the joint limits or the workspace (no inverse kinematics solution) stops the arm where it is.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from ruckig import ControlInterface, InputParameter, Result, Ruckig, Synchronization, Trajectory

from ...model import kinematics as kin
from ...model import rotations as rot
from ..core.controller_protocol import Controller
from ..core.controller_state import part_of
from ..core.state_machine import STATE_MOVING, STATE_SLEEP, Event, fire
from . import reduced

#: Modes of register 19 (SDK vocabulary): joint and Cartesian velocity control.
MODE_JOINT_VELOCITY = 4
MODE_CARTESIAN_VELOCITY = 5

#: The rotational part of a Cartesian velocity ramps with the joint acceleration and jerk.

#: A velocity below this (rad/s or mm/s) counts as rest for the motion state.
REST = 1e-9


@dataclass(slots=True)
class VelocityControl:
    """The commanded velocity of mode 4 or 5 and the arm's present velocity along the ramp."""

    mode: int = MODE_JOINT_VELOCITY
    target: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: Joint velocities (mode 4) or the TCP twist in the base frame (mode 5: mm/s, rad/s) now.
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    acceleration: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sync: bool = True
    tool_frame: bool = False
    #: Controller time at which the commanded velocity returns to zero (None: never).
    until: float | None = None
    last_step: int = -2

    def stop(self) -> None:
        self.target = np.zeros_like(self.target)
        self.until = None


def control_of(ctl: Controller) -> VelocityControl:
    """The velocity control state of ``ctl`` (created at rest on first use)."""
    return part_of(ctl.data, "velocity_control", VelocityControl)


def _size(mode: int, dof: int) -> int:
    return dof if mode == MODE_JOINT_VELOCITY else 6


def _reset(vc: VelocityControl, mode: int, dof: int) -> None:
    n = _size(mode, dof)
    vc.mode = mode
    vc.target = np.zeros(n)
    vc.velocity = np.zeros(n)
    vc.acceleration = np.zeros(n)
    vc.until = None


def command(ctl: Controller, mode: int, target: np.ndarray, *, sync: bool = True, tool_frame: bool = False,
            duration: float | None = None) -> None:
    """Registers 81/82: command a velocity (already in rad/s or mm/s; checked by the caller)."""
    vc = control_of(ctl)
    if vc.mode != mode or vc.last_step != ctl.steps - 1 or vc.target.size != _size(mode, ctl.dof):
        _reset(vc, mode, ctl.dof)
    vc.target = np.asarray(target, dtype=float).copy()
    vc.last_step = ctl.steps  # the next control period continues this command
    vc.sync = sync
    vc.tool_frame = tool_frame
    vc.until = ctl.time + duration if duration is not None and duration > 0.0 else None


def _limits(ctl: Controller, mode: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(speed, acceleration, jerk) limits per component of the controlled velocity."""
    s = ctl.settings
    m = ctl.model
    reduced = reduced_limits(ctl)
    if mode == MODE_JOINT_VELOCITY:
        vmax = m.max_joint_speed if reduced is None else min(m.max_joint_speed, reduced[1])
        n = ctl.dof
        return np.full(n, vmax), np.full(n, s.joint_maxacc), np.full(n, s.joint_jerk)
    tcp_v = m.max_tcp_speed if reduced is None else min(m.max_tcp_speed, reduced[0])
    lin = [tcp_v] * 3
    ang = [m.max_joint_speed] * 3
    return (np.array(lin + ang), np.array([s.tcp_maxacc] * 3 + [s.joint_maxacc] * 3),
            np.array([s.tcp_jerk] * 3 + [s.joint_jerk] * 3))


def reduced_limits(ctl: Controller) -> tuple[float, float] | None:
    """(TCP speed mm/s, joint speed rad/s) maxima while reduced mode is on, else None."""
    tcp, joint = reduced.speed_caps(ctl)
    return None if tcp == float("inf") else (tcp, joint)


def _clip_target(target: np.ndarray, vmax: np.ndarray, mode: int) -> np.ndarray:
    out = np.clip(target, -vmax, vmax)
    if mode == MODE_CARTESIAN_VELOCITY:
        lin = float(np.linalg.norm(out[:3]))
        if lin > vmax[0]:
            out[:3] *= vmax[0] / lin
    return out


def _ramp(vc: VelocityControl, target: np.ndarray, vmax: np.ndarray, amax: np.ndarray,
          jmax: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration one period later on the jerk-limited ramp towards ``target``."""
    if np.allclose(vc.velocity, target, rtol=0.0, atol=1e-12) and not np.any(vc.acceleration):
        return target.copy(), np.zeros_like(target)
    n = target.size
    inp = InputParameter(n)
    inp.control_interface = ControlInterface.Velocity
    inp.current_position = [0.0] * n
    inp.current_velocity = list(vc.velocity)
    inp.current_acceleration = list(vc.acceleration)
    inp.target_velocity = list(target)
    inp.target_acceleration = [0.0] * n
    inp.max_velocity = list(np.maximum(vmax, np.abs(vc.velocity)) + 1.0)
    inp.max_acceleration = list(amax)
    inp.max_jerk = list(jmax)
    inp.synchronization = Synchronization.Time if vc.sync else Synchronization.No
    traj = Trajectory(n)
    result = Ruckig(n).calculate(inp, traj)
    if result not in (Result.Working, Result.Finished) or traj.duration <= dt:
        return target.copy(), np.zeros_like(target)
    _, v, a = traj.at_time(dt)
    return np.asarray(v, dtype=float), np.asarray(a, dtype=float)


def step(ctl: Controller, dt: float) -> None:
    """One control period of mode 4 or 5 (called by the core while the mode is active)."""
    vc = control_of(ctl)
    mode = ctl.mode
    fresh = vc.last_step != ctl.steps - 1
    vc.last_step = ctl.steps
    if fresh or vc.mode != mode or vc.target.size != _size(mode, ctl.dof):
        _reset(vc, mode, ctl.dof)
    if ctl.motion_state not in (STATE_SLEEP, STATE_MOVING):
        _reset(vc, mode, ctl.dof)  # stop, suspend or reset: commanded velocity dropped
        return
    if vc.until is not None and ctl.time >= vc.until - 1e-9:
        vc.stop()
    vmax, amax, jmax = _limits(ctl, mode)
    target = _clip_target(vc.target, vmax, mode)
    v, a = _ramp(vc, target, vmax, amax, jmax, dt)
    if mode == MODE_JOINT_VELOCITY:
        v = _joint_limit_brake(ctl, v, amax)
        q = ctl.q + 0.5 * (vc.velocity + v) * dt
        lo, hi = _joint_range(ctl)
        q = np.clip(q, lo, hi)
        ctl.q = q
    else:
        q_new = _cartesian_step(ctl, vc, v, dt)
        if q_new is None:
            _reset(vc, mode, ctl.dof)
            fire(ctl, Event.SERVO_AT_TARGET)
            return
        ctl.q = q_new
    vc.velocity, vc.acceleration = v, a
    moving = bool(np.any(np.abs(v) > REST))  # held on a joint limit: at rest (state 2)
    fire(ctl, Event.SERVO_MOVING if moving else Event.SERVO_AT_TARGET)


def _joint_range(ctl: Controller) -> tuple[np.ndarray, np.ndarray]:
    return reduced.joint_range(ctl)


def _joint_limit_brake(ctl: Controller, v: np.ndarray, amax: np.ndarray) -> np.ndarray:
    """Slow each joint so that it can stop on its limit at the maximum acceleration."""
    lo, hi = _joint_range(ctl)
    room = np.where(v > 0.0, hi - ctl.q, ctl.q - lo)
    allowed = np.sqrt(2.0 * amax * np.maximum(room, 0.0))
    return np.sign(v) * np.minimum(np.abs(v), allowed)


def _cartesian_step(ctl: Controller, vc: VelocityControl, v: np.ndarray, dt: float) -> np.ndarray | None:
    """Joints after moving the TCP by the twist ``v`` (tool or base frame) for ``dt``; None when that
    pose cannot be reached within the joint limits."""
    if not np.any(v) and not np.any(vc.velocity):
        return np.asarray(ctl.q, dtype=float).copy()
    twist = 0.5 * (vc.velocity + v) * dt
    T = ctl.tcp_matrix().copy()
    R = T[:3, :3]
    dR = rot.pose_aa_to_matrix(np.array([0.0, 0.0, 0.0, *twist[3:]]))[:3, :3]
    if vc.tool_frame:
        T[:3, 3] = T[:3, 3] + R @ twist[:3]
        T[:3, :3] = R @ dR
    else:
        T[:3, 3] = T[:3, 3] + twist[:3]
        T[:3, :3] = dR @ R
    q = kin.ik(ctl.model, ctl.flange_target(T), ctl.q, limited=False)
    if q is None:
        return None
    lo, hi = _joint_range(ctl)
    if np.any(q < lo) or np.any(q > hi):
        return None
    if float(np.max(np.abs(q - ctl.q))) > ctl.model.max_joint_speed * dt * 1.05:
        return None
    return np.asarray(q, dtype=float)



#: Modes beyond the manual's, each with the register that commands it: register 19 accepts such a
#: mode on a box whose register table has that register (not on the manual's box, ``DEFAULT_VERSION``).
MODE_REGISTERS: dict[int, int] = {MODE_JOINT_VELOCITY: 81, MODE_CARTESIAN_VELOCITY: 82}
