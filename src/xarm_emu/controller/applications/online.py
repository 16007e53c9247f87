"""Online trajectory planning: joint (mode 6) and Cartesian (mode 7) modes of register 19.

In these modes a joint move (register 23, 24) or a linear move (register 21) is not queued: its
target replaces the one the arm is heading for. The arm re-plans at the next control period from
its present position, velocity and acceleration (ruckig's offline planner, state to state) within
the jerk and acceleration limits (registers 31-34) and the command's speed and acceleration (capped
by reduced mode, registers 47/48), so a new target mid-move takes over without a stop and the arm
ends at rest on the last target.

Mode 7 plans the TCP in six coordinates: the position (mm) and the rotation vector (rad, base
frame) from the orientation at the moment of re-planning; each period the pose is solved to joints
(no solution: C21; a pose needing joints outside their limits: C23).

The modes are answered by the 2.x controllers (``FirmwareProfile.online_modes``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...model import kinematics as kin
from ...model import rotations as rot
from .. import motion
from ..core.controller_protocol import Controller
from ..core.controller_state import part_of
from ..core.interface import C_JOINT_LIMIT, C_KINEMATIC, CommandError, NotReady, ParameterError, Values
from ..core.poses import wire_pose_to_matrix
from ..core.settings import in_range
from ..core.state_machine import STATE_MOVING, STATE_SLEEP, Event, fire
from . import reduced

MODE_JOINT_ONLINE = 6
MODE_CARTESIAN_ONLINE = 7



@dataclass(slots=True)
class OnlinePlanner:
    """The target of mode 6 or 7 and the trajectory towards it."""

    mode: int = MODE_JOINT_ONLINE
    traj: motion.JointTrajectory | None = None
    t: float = 0.0
    #: Mode 7: the orientation the rotation-vector coordinates are measured from.
    r_ref: np.ndarray = field(default_factory=lambda: np.eye(3))
    #: A new target (coordinates, speed, acc) waiting for the next control period.
    pending: tuple[np.ndarray, float, float] | None = None
    last_step: int = -2
    #: Present state of the planned coordinates (joints, or xyz + rotation vector).
    state: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    #: Targets taken over so far (each one re-planned the motion).
    replans: int = 0


def planner_of(ctl: Controller) -> OnlinePlanner:
    """The online planner's state of ``ctl`` (modes 6 and 7)."""
    return part_of(ctl.data, "online_planner", OnlinePlanner)


def _require(ctl: Controller, mode: int) -> None:
    if ctl.error_code or not ctl.ready or ctl.mode != mode:
        raise NotReady()


def _speed(v: Values, vmax: float, amax: float) -> tuple[float, float]:
    speed, acc = float(v["speed"]), float(v["acc"])
    if not (in_range(speed, vmax) and speed > 0.0 and in_range(acc, amax) and acc > 0.0):
        raise ParameterError("speed or acceleration outside Table 1.2")
    return speed, acc


def _unchanged(values: Any, current: np.ndarray) -> np.ndarray:
    """+inf ("unchanged", ``FirmwareProfile.inf_unchanged``) takes the component of ``current``."""
    out = np.asarray([float(x) for x in values], dtype=float)[: current.size]
    inf = np.isinf(out) & (out > 0)
    out[inf] = current[: out.size][inf]
    return out


def joint_target(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 23 (or 24) in mode 6: the joints head for this target from now on."""
    if "joints" not in v:  # register 24's one-byte form (torque or current in the reports)
        return ctl.handler_of(24)(v)  # type: ignore[return-value]
    m = ctl.model
    speed, acc = _speed(v, m.max_joint_speed, m.max_joint_acc)
    _require(ctl, MODE_JOINT_ONLINE)
    p = planner_of(ctl)
    current = p.traj.target if p.traj is not None and p.mode == MODE_JOINT_ONLINE else ctl.q
    q = _unchanged(v["joints"], np.asarray(current))[: ctl.dof]
    if not kin.within_limits(m, q):
        raise CommandError(C_JOINT_LIMIT, "joint target outside the limits")
    if int(v.get("only_check_type", 0) or 0) > 0:
        return {"cmdnum": 0, "check_result": 0}
    p.pending = (q, speed, acc)
    return {"cmdnum": 0}


def cartesian_target(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 21 in mode 7: the TCP heads for this pose (base frame) from now on."""
    m = ctl.model
    speed, acc = _speed(v, m.max_tcp_speed, m.max_tcp_acc)
    if int(v.get("coord", 0)) != 0 or int(v.get("is_axis_angle", 0)) != 0:
        raise ParameterError("mode 7 takes base-frame RPY targets")
    _require(ctl, MODE_CARTESIAN_ONLINE)
    current = rot.matrix_to_pose(ctl.tcp_matrix())
    pose = _unchanged(v["pose"], current)
    T = wire_pose_to_matrix(tuple(pose))
    if kin.ik(m, ctl.flange_target(T), ctl.q, limited=True, restarts=True) is None:
        raise CommandError(C_KINEMATIC, "target pose has no inverse kinematics solution")
    if int(v.get("only_check_type", 0) or 0) > 0:
        return {"cmdnum": 0, "check_result": 0}
    planner_of(ctl).pending = (T, speed, acc)
    return {"cmdnum": 0}


def _coords(T: np.ndarray, r_ref: np.ndarray) -> np.ndarray:
    """xyz (mm) and the base-frame rotation vector of ``T`` relative to ``r_ref``."""
    rv = rot.matrix_to_axis_angle(T[:3, :3] @ r_ref.T)
    return np.concatenate([T[:3, 3], rv])


def _pose(c: np.ndarray, r_ref: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = rot.axis_angle_to_matrix(c[3:]) @ r_ref
    T[:3, 3] = c[:3]
    return T


def _replan(ctl: Controller, p: OnlinePlanner) -> None:
    assert p.pending is not None
    target, speed, acc = p.pending
    p.pending = None
    s = ctl.settings
    tcp_cap, joint_cap = reduced.speed_caps(ctl)
    speed = min(speed, joint_cap if p.mode == MODE_JOINT_ONLINE else tcp_cap)
    if p.mode == MODE_JOINT_ONLINE:
        q, qd, qdd = p.state if p.state is not None else (ctl.q.copy(), np.zeros(ctl.dof), np.zeros(ctl.dof))
        p.traj = motion.plan_joint_move(q, target, speed, min(acc, s.joint_maxacc), s.joint_jerk,
                                        qd0=qd, qdd0=qdd)
    else:
        if p.state is None:
            here = ctl.tcp_matrix()
            p.r_ref = here[:3, :3].copy()
            c, cd, cdd = _coords(here, p.r_ref), np.zeros(6), np.zeros(6)
        else:
            # Re-measure the rotation from the present orientation (continuous: same pose, velocity).
            c0, cd, cdd = p.state
            here = _pose(c0, p.r_ref)
            p.r_ref = here[:3, :3].copy()
            c = _coords(here, p.r_ref)
        goal = _coords(target, p.r_ref)
        vmax = [speed] * 3 + [ctl.model.max_joint_speed] * 3
        amax = [min(acc, s.tcp_maxacc)] * 3 + [s.joint_maxacc] * 3
        jmax = [s.tcp_jerk] * 3 + [s.joint_jerk] * 3
        p.traj = motion.plan_joint_move(c, goal, vmax, amax, jmax, qd0=cd, qdd0=cdd)
    p.t = 0.0
    p.replans += 1


def step(ctl: Controller, dt: float) -> None:
    """One control period of mode 6 or 7."""
    p = planner_of(ctl)
    fresh = p.last_step != ctl.steps - 1 or p.mode != ctl.mode
    p.last_step = ctl.steps
    if fresh:  # the mode was (re)entered: plan from rest where the arm is
        p.mode, p.traj, p.state = ctl.mode, None, None
    if ctl.motion_state not in (STATE_SLEEP, STATE_MOVING):
        p.traj = p.state = p.pending = None  # stop, suspend or reset: the target is dropped
        return
    if p.pending is not None:
        _replan(ctl, p)
    if p.traj is None:
        fire(ctl, Event.SERVO_AT_TARGET)
        return
    p.t += dt
    c, cd, cdd = p.traj.at(p.t)
    if p.mode == MODE_JOINT_ONLINE:
        q = c
    else:
        sol = kin.ik(ctl.model, ctl.flange_target(_pose(c, p.r_ref)), ctl.q, limited=False)
        if sol is None:
            p.traj = p.state = None
            raise CommandError(C_KINEMATIC, "no inverse kinematics solution along the online path")
        q = np.asarray(sol, dtype=float)
    if not kin.within_limits(ctl.model, q):
        p.traj = p.state = None
        raise CommandError(C_JOINT_LIMIT, "online path leaves the joint limits")
    ctl.q = np.asarray(q, dtype=float).copy()
    done = p.t >= p.traj.duration
    p.state = (c, cd, cdd)
    if done:
        p.traj = None
        p.state = (c, np.zeros_like(cd), np.zeros_like(cdd))
    fire(ctl, Event.SERVO_AT_TARGET if done else Event.SERVO_MOVING)
