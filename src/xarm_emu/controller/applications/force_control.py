"""Admittance control (application 1) and force control (application 2) on the six-axis F/T sensor
(registers 202, 203 and 207-211, which come with the sensor's own; the SDK's ``set_ft_sensor_mode``,
``set_ft_sensor_admittance_parameters``, ``set_ft_sensor_force_parameters``).

Both applications run in position mode (0) once the arm is ready: register 202 ends the present
motion like a mode change and the application starts at the first control period after the state
is set to 0 again (register 12), which is the order the SDK's F/T example programs follow. While it
runs, every control period (4 ms) reads the sensor's compensated wrench, moves the TCP along the
enabled axes of the chosen frame (0 base, 1 tool) and leaves the other axes where they were when
the application started:

- **admittance** (1): each enabled axis is the mass-spring-damper ``M a + B v + K x = F`` with ``x``
  the displacement from the start pose and ``F`` the external wrench (N, N m; ``M`` kg or kg m^2,
  ``K`` N/m or N m/rad, ``B`` N s/m or N m s/rad, the units of the SDK's docstrings). The law is
  integrated exactly over each period with the wrench held, so the motion is the continuous law's
  sampled every 4 ms. ``B = 0`` (the SDK's examples call damping reserved and send zeros) takes the
  box's own damping, :data:`DEFAULT_DAMPING`.
- **force control** (2): each enabled axis moves so that the force the arm applies to its
  environment (the opposite of the external wrench) tracks the reference of register 209. The PID of
  register 208 turns the force error (N, N m) into a displacement per control period (mm, rad); its
  speed is capped at ``xe_limit`` (mm/s, rad/s), the "max adjust velocity" of the SDK's example.

The joints follow the TCP through inverse kinematics within the joint speed limit (a faster step is
shortened). A step that would leave the joint limits or the workspace is shortened as far as it
must; when nothing of it can be followed the arm stops there without an error, as Cartesian
velocity control does (controller/applications/velocity.py), and moves again once pushed another way. Queued
motion commands run as usual while an application is on; the application starts again from
wherever they leave the arm. The wrench is the sensor's reading of the period before
(``devices/ft_sensor.control_wrench``, handed in by the core each period), turned from the sensor's
axes into the tool's by the TCP offset's rotation (register 35).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, cast

import numpy as np

from ...model import kinematics as kin
from ...model import rotations as rot
from ..core.controller_protocol import Controller
from ..core.controller_state import part_of
from ..core.ft_config import ft_config
from ..core.state_machine import STATE_MOVING, STATE_SLEEP, Event, fire
from . import reduced

APP_OFF = 0
APP_ADMITTANCE = 1
APP_FORCE = 2
APPS = (APP_OFF, APP_ADMITTANCE, APP_FORCE)

#: Frames of registers 207, 209 and 211.
FRAME_BASE = 0
FRAME_TOOL = 1

# The vendor's ranges, as the SDK checks them before it sends registers 207/210 and 208/209
# (linear axes x, y, z first, then the rotations about them).
M_RANGES = ((0.02, 1.0),) * 3 + ((0.0001, 0.01),) * 3
K_RANGES = ((0.0, 2000.0),) * 3 + ((0.0, 20.0),) * 3
KP_RANGE = (0.0, 0.05)
KI_RANGE = (0.0, 0.0005)
KD_RANGE = (0.0, 0.05)
XE_LIMIT_RANGE = (0.0, 200.0)
F_REF_MAX = (150.0, 150.0, 200.0, 4.0, 4.0, 4.0)

#: The box's damping where ``B`` is sent as 0 (N s/m, N m s/rad): without stiffness a steady 10 N
#: moves the TCP at 100 mm/s and a steady 1 N m turns it at 0.5 rad/s; with any M and K in the
#: vendor's ranges it is at least critical (2 sqrt(M K) <= 89 N s/m, 0.9 N m s/rad), so the TCP
#: settles on F/K without overshoot.
DEFAULT_DAMPING = (100.0, 100.0, 100.0, 2.0, 2.0, 2.0)

#: A speed below this (mm/s, rad/s) counts as rest for the motion state.
REST = 1e-6



# -- parameter checks ------------------------------------------------------------------------------

def _slack(bound: float) -> float:
    """How far a bound may be passed by the fp32 rounding of the wire (a bound itself is inside)."""
    return abs(bound) * 1e-6 + 1e-12 if math.isfinite(bound) else 0.0


def _outside(name: str, values: Sequence[float], ranges: Sequence[tuple[float, float]]) -> str | None:
    for i, (x, (lo, hi)) in enumerate(zip(values, ranges, strict=True)):
        if not lo - _slack(lo) <= x <= hi + _slack(hi):
            return f"{name}[{i}] = {x:g} outside [{lo:g}, {hi:g}]"
    return None


def mkb_problem(M: Sequence[float], K: Sequence[float], B: Sequence[float]) -> str | None:
    """Why ``M``, ``K``, ``B`` are outside the vendor's ranges (None when they are inside)."""
    return (_outside("M", M, M_RANGES) or _outside("K", K, K_RANGES)
            or _outside("B", B, ((0.0, math.inf),) * 6))


def pid_problem(kp: Sequence[float], ki: Sequence[float], kd: Sequence[float],
                xe_limit: Sequence[float]) -> str | None:
    """Why the force-control PID is outside the vendor's ranges (None when it is inside)."""
    return (_outside("kp", kp, (KP_RANGE,) * 6) or _outside("ki", ki, (KI_RANGE,) * 6)
            or _outside("kd", kd, (KD_RANGE,) * 6) or _outside("xe_limit", xe_limit, (XE_LIMIT_RANGE,) * 6))


def f_ref_problem(f_ref: Sequence[float]) -> str | None:
    """Why the force reference is outside the vendor's range (None when it is inside)."""
    return _outside("f_ref", f_ref, tuple((-m, m) for m in F_REF_MAX))


# -- the admittance law ----------------------------------------------------------------------------

def effective_damping(B: Sequence[float]) -> np.ndarray:
    """The damping each axis runs with: ``B`` where given, else :data:`DEFAULT_DAMPING`."""
    b = np.asarray(B, dtype=float)
    return np.where(b > 0.0, b, np.asarray(DEFAULT_DAMPING))


def _expm(A: np.ndarray) -> np.ndarray:
    """Matrix exponential by scaling and squaring of a Taylor series (small matrices)."""
    norm = float(np.max(np.sum(np.abs(A), axis=1)))
    s = max(0, math.ceil(math.log2(norm)) + 1) if norm > 0.5 else 0
    X = A / (2.0 ** s)
    out = np.eye(A.shape[0])
    term = np.eye(A.shape[0])
    for n in range(1, 20):
        term = term @ X / n
        out = out + term
    for _ in range(s):
        out = out @ out
    return out


@lru_cache(maxsize=256)
def discrete_law(m: float, k: float, b: float, dt: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Exact one-period map of ``m a + b v + k x = f`` with ``f`` held over ``dt``:
    ``(x, v)' = Ad (x, v) + Bd f``, returned as (Ad row-major, Bd)."""
    A = np.array([[0.0, 1.0, 0.0], [-k / m, -b / m, 1.0 / m], [0.0, 0.0, 0.0]]) * dt
    E = _expm(A)
    return (float(E[0, 0]), float(E[0, 1]), float(E[1, 0]), float(E[1, 1])), (float(E[0, 2]), float(E[1, 2]))


def admittance_update(x: np.ndarray, v: np.ndarray, wrench: np.ndarray, M: Sequence[float],
                      K: Sequence[float], B: Sequence[float], axes: Sequence[int],
                      dt: float) -> tuple[np.ndarray, np.ndarray]:
    """One period of the admittance law on the enabled ``axes``: displacement ``x`` (m, rad) and
    velocity ``v`` (m/s, rad/s) after ``dt`` under ``wrench`` (N, N m); other axes stay at rest."""
    b_eff = effective_damping(B)
    x_new, v_new = np.zeros(6), np.zeros(6)
    for i in range(6):
        if not axes[i] or not M[i] > 0.0:  # an axis never given a mass stays where it is
            continue
        (a00, a01, a10, a11), (b0, b1) = discrete_law(float(M[i]), float(K[i]), float(b_eff[i]), dt)
        f = float(wrench[i])
        x_new[i] = a00 * x[i] + a01 * v[i] + b0 * f
        v_new[i] = a10 * x[i] + a11 * v[i] + b1 * f
    return x_new, v_new


# -- the force-control law -------------------------------------------------------------------------

@dataclass(slots=True)
class Pid:
    """The force-control PID's memory: the error sum and the last error per axis."""

    integral: np.ndarray = field(default_factory=lambda: np.zeros(6))
    last_error: np.ndarray | None = None


def force_update(pid: Pid, applied: np.ndarray, f_ref: Sequence[float], kp: Sequence[float],
                 ki: Sequence[float], kd: Sequence[float], xe_limit: Sequence[float],
                 axes: Sequence[int], dt: float) -> np.ndarray:
    """One period of force control: the velocity (mm/s, rad/s) of each enabled axis that moves the
    ``applied`` force (what the arm exerts, N, N m) towards ``f_ref``. The PID's output is a
    displacement per period (mm or rad per N or N m); its speed is capped at ``xe_limit`` and the
    error sum stops growing while the cap holds (no wind-up)."""
    error = np.asarray(f_ref, dtype=float) - np.asarray(applied, dtype=float)
    last = error if pid.last_error is None else pid.last_error
    on = np.asarray(axes, dtype=bool)
    kp_, ki_, kd_ = (np.asarray(g, dtype=float) for g in (kp, ki, kd))
    u = kp_ * error + ki_ * (pid.integral + error) + kd_ * (error - last)
    v = u / dt
    cap = np.asarray(xe_limit, dtype=float)
    capped = np.abs(v) > cap
    v = np.clip(v, -cap, cap)
    pid.integral = np.where(on & ~capped, pid.integral + error, pid.integral)
    pid.last_error = error
    return np.where(on, v, 0.0)


# -- the per-period step ---------------------------------------------------------------------------

@dataclass(slots=True)
class ForceControl:
    """The application of register 202 and what it runs on (in the controller's state)."""

    app: int = APP_OFF
    #: Whether the application runs (register 212's "started"): set at the first period after
    #: the state is set to 0, cleared when the arm stops.
    started: bool = False
    frame: int = FRAME_BASE
    #: The TCP pose (4x4, mm, user frame) the displacement is measured from.
    anchor: np.ndarray | None = None
    #: Displacement from ``anchor`` (mm, rad) and its velocity (mm/s, rad/s), in ``frame``.
    x: np.ndarray = field(default_factory=lambda: np.zeros(6))
    v: np.ndarray = field(default_factory=lambda: np.zeros(6))
    pid: Pid = field(default_factory=Pid)
    #: The direction of the last step that could not be followed: further steps that way stop at
    #: once (the arm is on the edge of its workspace or a joint limit).
    blocked: np.ndarray | None = None

    def restart(self) -> None:
        """Start again from the present pose at the next period that runs."""
        self.started = False
        self.anchor = None
        self.x = np.zeros(6)
        self.v = np.zeros(6)
        self.pid = Pid()
        self.blocked = None


def control_of(ctl: Controller) -> ForceControl:
    """The force-control state of ``ctl`` (created, off, on first use)."""
    return part_of(ctl.data, "force_control", ForceControl)


def set_app(ctl: Controller, app: int) -> None:
    """Register 202 (checked by the handler): 1 or 2 ends the present motion like a mode change and
    waits for the state to be set to 0; 0 stops the application where the arm is."""
    fc = control_of(ctl)
    fc.app = app
    fc.restart()
    if app != APP_OFF:
        ctl.system_reset()
    elif ctl.motion_state == STATE_MOVING and not ctl.executor.active:
        fire(ctl, Event.IDLE)


def to_frame(R_tool: np.ndarray, wrench_tool: np.ndarray, frame: int) -> np.ndarray:
    """A wrench given in the tool frame (TCP axes ``R_tool`` in the user frame), expressed in
    ``frame``."""
    if frame == FRAME_TOOL:
        return np.asarray(wrench_tool, dtype=float)
    w = np.asarray(wrench_tool, dtype=float)
    return np.concatenate([R_tool @ w[:3], R_tool @ w[3:]])


def target_pose(anchor: np.ndarray, x: np.ndarray, frame: int) -> np.ndarray:
    """The TCP pose (4x4, mm) displaced by ``x`` (mm, rad: translation and rotation vector) from
    ``anchor`` along the axes of ``frame`` (the base frame, or the anchor's tool frame)."""
    T = anchor.copy()
    dR = rot.axis_angle_to_matrix(x[3:])
    if frame == FRAME_TOOL:
        T[:3, 3] = anchor[:3, 3] + anchor[:3, :3] @ x[:3]
        T[:3, :3] = anchor[:3, :3] @ dR
    else:
        T[:3, 3] = anchor[:3, 3] + x[:3]
        T[:3, :3] = dR @ anchor[:3, :3]
    return T


def runs(ctl: Controller) -> bool:
    """Whether an application is set, the arm is in position mode and ready, and no queued command
    is running: then :func:`step` moves the arm this period."""
    fc = cast("ForceControl | None", ctl.data.force_control)
    return (fc is not None and fc.app != APP_OFF and ctl.mode == 0
            and ctl.motion_state in (STATE_SLEEP, STATE_MOVING) and not ctl.executor.active)


def period(ctl: Controller, dt: float, sensor_wrench: Callable[[Controller], np.ndarray | None]) -> bool:
    """The core's call each control period in position mode: run the application when it
    :func:`runs` (True: this period's motion is done), else let queued commands run (False).
    ``sensor_wrench(ctl)`` answers the sensor's control wrench (sensor frame, torques about the TCP), or
    None while the sensor is switched off."""
    fc = cast("ForceControl | None", ctl.data.force_control)
    if fc is None or fc.app == APP_OFF:
        return False
    if not runs(ctl):
        fc.restart()  # stopped, suspended or running a queued command: start again afterwards
        return False
    wrench = sensor_wrench(ctl)
    if wrench is None:  # the sensor was switched off: the application ends
        fc.app = APP_OFF
        fc.restart()
        fire(ctl, Event.SERVO_AT_TARGET)
        return True
    step(ctl, dt, sensor_to_tool(ctl.settings.tcp_offset, wrench))
    return True


def engaged(ctl: Controller) -> bool:
    """Whether admittance or force control is set (register 202): it acts on every period's reading."""
    fc = cast("ForceControl | None", ctl.data.force_control)
    return fc is not None and fc.app != APP_OFF


def sensor_to_tool(tcp_offset: Sequence[float], wrench: Any) -> np.ndarray:
    """A wrench in the sensor frame (the flange's axes, torques about the TCP point) in the tool
    frame, whose axes register 35's TCP offset turns from the flange's."""
    w = np.asarray(wrench, dtype=float)
    if not any(tcp_offset[3:6]):
        return w
    R = rot.rpy_to_matrix(*(float(a) for a in tcp_offset[3:6]))
    return np.concatenate([R.T @ w[:3], R.T @ w[3:]])


def step(ctl: Controller, dt: float, wrench_tool: np.ndarray) -> None:
    """One control period of the application under ``wrench_tool`` (the sensor's compensated wrench
    in the tool frame, N and N m); moves ``ctl.q``."""
    fc = control_of(ctl)
    cfg = ft_config(ctl)
    T_now = ctl.tcp_matrix()
    if not fc.started:
        fc.restart()
        fc.started = True
        fc.anchor = T_now.copy()
        fc.frame = cfg.imp_coord if fc.app == APP_ADMITTANCE else cfg.fc_coord
    assert fc.anchor is not None
    w = to_frame(T_now[:3, :3], wrench_tool, fc.frame)
    x_prev = fc.x.copy()
    if fc.app == APP_ADMITTANCE:
        si = np.array([1e-3] * 3 + [1.0] * 3)  # mm -> m for the law, rad stays
        x_si, v_si = admittance_update(fc.x * si, fc.v * si, w, cfg.M, cfg.K, cfg.B, cfg.imp_c_axis, dt)
        x_new, v_new = x_si / si, v_si / si
    else:
        pid = cfg.pid
        v_new = force_update(fc.pid, -w, cfg.f_ref, pid["kp"], pid["ki"], pid["kd"], pid["xe_limit"],
                             cfg.fc_c_axis, dt)
        x_new = fc.x + v_new * dt
    step_dir = x_new - x_prev
    if fc.blocked is not None and float(np.dot(step_dir, fc.blocked)) > 0.0:
        q = None  # still pushing where the arm cannot go
    else:
        q = _follow(ctl, fc, x_prev, x_new)
    if q is None:  # outside the joint limits or the workspace: the arm stops where it is
        fc.x, fc.v = x_prev, np.zeros(6)
        if np.any(step_dir):
            fc.blocked = step_dir
        fire(ctl, Event.SERVO_AT_TARGET)
        return
    fc.blocked = None
    q_new, scale = q
    if scale < 1.0:
        x_new = x_prev + (x_new - x_prev) * scale
        v_new = (x_new - x_prev) / dt
    fc.x, fc.v = x_new, v_new
    ctl.q = q_new
    moving = bool(np.any(np.abs(x_new - x_prev) > REST * dt))
    fire(ctl, Event.SERVO_MOVING if moving else Event.SERVO_AT_TARGET)


def _follow(ctl: Controller, fc: ForceControl, x_prev: np.ndarray,
            x_new: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Joints that put the TCP at displacement ``x_new``, or part of the way (the fraction returned)
    when the whole step would leave the joint limits or the workspace or exceed the joint speed
    limit; None when not even a small part of it can be followed."""
    assert fc.anchor is not None
    q_now = np.asarray(ctl.q, dtype=float)
    if np.array_equal(x_new, x_prev):
        return q_now.copy(), 1.0
    lo, hi = reduced.joint_range(ctl)
    limit = ctl.model.max_joint_speed * ctl.period
    scale = 1.0
    for _ in range(8):
        x = x_prev + (x_new - x_prev) * scale
        q = kin.ik(ctl.model, ctl.flange_target(target_pose(fc.anchor, x, fc.frame)), q_now, limited=False)
        if q is None or np.any(q < lo) or np.any(q > hi):
            scale *= 0.5  # towards the edge of the workspace or a joint limit, in ever smaller steps
            continue
        fastest = float(np.max(np.abs(q - q_now)))
        if fastest <= limit * 1.0001:
            return np.asarray(q, dtype=float), scale
        scale *= 0.95 * limit / fastest
    return None
