"""The control box: state machine, command dispatch, motion, errors and warnings.

Pure and deterministic: no sockets, no wall clock. The server calls
:meth:`Controller.handle` for every request and :meth:`Controller.step` once
per control period (:data:`~xarm_emu.controller.base.PERIOD`).

States (register 13, manual section 2.1.3): 1 in motion, 2 sleep (idle and
ready), 3 suspend, 4 stop, 5 system reset. Modes (register 19): 0 position,
1 servo, 2 joint teaching, 3 Cartesian teaching (not available).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..model import collision
from ..model import dynamics as dyn
from ..model import kinematics as kin
from ..model import rotations as rot
from ..model.robots import RobotModel
from ..protocol import registers as regs
from ..protocol.frame import STATE_ERROR, STATE_NOT_READY, STATE_WARNING
from ..protocol.layouts import LayoutError, all_finite
from . import motion, safety
from .base import (
    PERIOD,
    WARN_BUFFER_OVERFLOW,
    WARN_NO_SOLUTION,
    WARN_PARAMETER,
    WARN_UNKNOWN_COMMAND,
    CommandError,
    CommandWarning,
    Component,
    Handler,
    ParameterError,
    Values,
)
from .commands import CircleMove, Dwell, JointMove, LineMove, QueuedCommand
from .executor import Executor, Limits, wire_pose_to_matrix
from .settings import (
    COLLISION_SENSITIVITY_RANGE,
    TEACH_SENSITIVITY_RANGE,
    Settings,
    in_range,
)

STATE_MOVING = 1
STATE_SLEEP = 2
STATE_SUSPEND = 3
STATE_STOP = 4
STATE_SYSTEM_RESET = 5

MODE_POSITION = 0
MODE_SERVO = 1
MODE_JOINT_TEACH = 2
MODE_CARTESIAN_TEACH = 3

#: Command buffer capacity; the SDK throttles itself at 512 (max_cmdnum).
BUFFER_CAPACITY = 1024

#: Firmware version the emulator claims. v1.6.0 keeps the SDK on the manual's
#: layouts (research note section 5.3).
FIRMWARE_VERSION = "v1.6.0"

# Control box errors (section 3.2.1) that need the joints enabled again after clearing.
_REENABLE_ERRORS = frozenset({1, 2, 3, 10, 11, 12, 13, 14, 15, 16, 17})

C_JOINT_LIMIT = 23
C_OTHER = 29

log = logging.getLogger("xarm_emu.controller")


class Controller:
    """One emulated control box with its arm."""

    def __init__(self, model: RobotModel, *, robot_sn: str = "XI1300", box_sn: str = "AC1300",
                 period: float = PERIOD) -> None:
        self.model = model
        self.dof = model.dof
        self.period = period
        self.robot_sn = robot_sn
        self.box_sn = box_sn
        self._time = 0.0
        self.steps = 0
        self.q = np.zeros(self.dof)
        self.qd = np.zeros(self.dof)
        self.qdd = np.zeros(self.dof)
        self._torque_cache: tuple[int, np.ndarray] | None = None
        self._state = STATE_STOP
        self.mode = MODE_POSITION
        self.enabled = [True] * self.dof
        self.brakes = [True] * self.dof  # True: brake released (motor holds the joint)
        self.error_code = 0
        self.warning_code = 0
        self.servo_errors = [0] * self.dof  # per-joint servo error codes (section 3.1)
        self.settings = Settings.for_model(self.model)
        self.simulation_robot = False  # register 79
        self._physical_q: np.ndarray | None = None
        self.collision_tool = collision.NO_TOOL
        #: (state, code) of the end tool for register 106; the emulator keeps it current.
        self.tool_error: tuple[int, int] = (0, 0)
        self.executor = Executor(model)
        self.servo_target: np.ndarray | None = None
        self.servo_tracker: motion.ServoTracker | None = None
        self.components: list[Component] = []
        self.counter = 0  # commands executed (rich report bytes 285-288)
        self._pose_cache: tuple[tuple[Any, ...], np.ndarray] | None = None
        self._handlers: dict[int, Handler] = self._core_handlers()
        self.on_save: Callable[[dict[str, Any]], None] | None = None
        self.on_clean_conf: Callable[[], None] | None = None
        self.shutdown_requested = False
        self._code = 0

    # -- components ----------------------------------------------------------------------------
    def add_component(self, component: Component) -> None:
        self.components.append(component)
        self._handlers.update(component.handlers())

    # -- ControllerView ------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return self._time

    @property
    def state(self) -> int:
        return self._state

    @property
    def is_moving(self) -> bool:
        return self._state == STATE_MOVING

    @property
    def tcp_position(self) -> tuple[float, float, float]:
        p = self.tcp_matrix()[:3, 3]
        return (float(p[0]), float(p[1]), float(p[2]))

    def raise_error(self, code: int) -> None:
        """Enter an error: stop at once, discard the buffer, state 4 (section 3.2.1)."""
        if self.error_code == 0 or code != self.error_code:
            self.error_code = code
        self.executor.clear()
        self.servo_target = None
        self.qd[:] = 0.0
        self._state = STATE_STOP
        self._enter_stop()

    def raise_warning(self, code: int) -> None:
        """Set a warning: only the flag and the code change (section 3.2.2)."""
        self.warning_code = code

    # -- readiness -----------------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        """Whether the arm can perform motion (reply bit 0x10 clear)."""
        return (self.error_code == 0 and self._state in (STATE_MOVING, STATE_SLEEP, STATE_SUSPEND)
                and all(self.enabled) and all(self.brakes))

    def status_byte(self) -> int:
        s = 0
        if self.error_code:
            s |= STATE_ERROR
        if self.warning_code:
            s |= STATE_WARNING
        if not self.ready:
            s |= STATE_NOT_READY
        return s

    # -- poses ---------------------------------------------------------------------------------
    def tcp_matrix(self, q: np.ndarray | None = None) -> np.ndarray:
        """TCP pose (4x4, mm) in the user frame, TCP offset applied."""
        if q is None:
            key = (self.q.tobytes(), tuple(self.settings.tcp_offset), tuple(self.settings.world_offset))
            if self._pose_cache is not None and self._pose_cache[0] == key:
                return self._pose_cache[1]
            T = kin.tcp_pose(self.model, self.q, self.settings.tcp_offset, self.settings.world_offset)
            self._pose_cache = (key, T)
            return T
        return kin.tcp_pose(self.model, q, self.settings.tcp_offset, self.settings.world_offset)

    def tcp_pose(self) -> np.ndarray:
        """(x, y, z, roll, pitch, yaw) of the TCP in the user frame (register 41)."""
        return rot.matrix_to_pose(self.tcp_matrix())

    def flange_target(self, T_tcp_user: np.ndarray) -> np.ndarray:
        return kin.flange_target(T_tcp_user, self.settings.tcp_offset, self.settings.world_offset)

    def joints7(self, q: np.ndarray | None = None) -> tuple[float, ...]:
        v = self.q if q is None else q
        return tuple(float(x) for x in v) + (0.0,) * (7 - self.dof)

    # -- request handling ----------------------------------------------------------------------
    def handle(self, code: int, params: bytes) -> tuple[int, bytes]:
        """Handle one command; returns (reply state byte, reply parameter bytes)."""
        reg = regs.get(code)
        handler = self._handlers.get(code)
        if reg is None or handler is None:
            self.raise_warning(WARN_UNKNOWN_COMMAND)
            return self.status_byte(), b""
        reply = b""
        self._code = code
        extra = 0
        try:
            try:
                values = reg.request.decode(params)
            except LayoutError as exc:
                raise ParameterError(str(exc)) from exc
            result = handler(values)
            if result is not None:
                reply = reg.reply.encode(result)
        except _NotReady:
            extra = STATE_NOT_READY  # this command cannot run now: nothing queued, nothing moves
            reply = self._default_reply(reg)
        except CommandWarning as w:
            self.raise_warning(w.code)
            reply = self._default_reply(reg)
        except CommandError as e:
            self.raise_error(e.code)
            reply = self._default_reply(reg)
        except Exception:  # a bug must not take the connection down: log it, answer warning 12
            log.exception("register %d with %d parameter bytes failed", code, len(params))
            self.raise_warning(WARN_PARAMETER)
            reply = self._default_reply(reg)
        return self.status_byte() | extra, reply

    def _default_reply(self, reg: regs.Register) -> bytes:
        """Reply bytes of a refused command: the buffer count for queued commands, else zeros.

        The SDK raises on short replies (research note section 0.4), so a refused getter still
        answers with its full layout.
        """
        if reg.reply.fields and reg.reply.fields[0].name == "cmdnum" and len(reg.reply.fields) == 1:
            return reg.reply.encode(cmdnum=self.executor.cmdnum)
        return bytes(reg.reply.size)

    # -- stepping ------------------------------------------------------------------------------
    def step(self) -> None:
        """Advance the control box by one control period."""
        dt = self.period
        self._time += dt
        self.steps += 1
        q_prev = self.q
        try:
            if self.error_code == 0:
                if self.mode == MODE_SERVO and self.servo_target is not None and self._state in (
                        STATE_SLEEP, STATE_MOVING):
                    tracker = self._tracker()
                    tracker.set_target(self.servo_target)
                    q, _, _ = tracker.step(dt)
                    self.q = q.copy()
                    self._state = STATE_SLEEP if tracker.at_target else STATE_MOVING
                elif self.mode == MODE_POSITION and self._state in (STATE_MOVING, STATE_SLEEP, STATE_SUSPEND):
                    self._step_position(dt)
                elif self._state == STATE_STOP and self.executor.stopping:
                    self._step_position(dt)
                if self.q is not q_prev:
                    self._check_safety(q_prev)
        except CommandError as e:
            self.raise_error(e.code)
        except Exception:  # keep the control loop alive; the arm stops with C29 "other errors"
            log.exception("control step failed")
            self.raise_error(C_OTHER)
        qd = (self.q - q_prev) / dt
        self.qdd = (qd - self.qd) / dt
        self.qd = qd
        for c in self.components:
            c.step(dt, self)

    def _check_safety(self, q_prev: np.ndarray) -> None:
        """Safety boundary (52, 59: C35) and self-collision (77, 78: C22) on the step just planned:
        the arm stops on the boundary or before contact (controller/safety.py)."""
        s = self.settings
        if not (s.boundary_on or s.self_collision_on):
            return
        stop = safety.check_path_step(self.model, q_prev, self.q, self.collision_tool, s.self_collision_on,
                                      s.boundary, s.boundary_on, s.tcp_offset)
        if stop is not None:
            self.q = np.asarray(stop.q_stop, dtype=float)
            raise CommandError(stop.code, stop.reason)

    def _limits(self) -> Limits:
        s = self.settings
        return Limits(s.tcp_jerk, s.tcp_maxacc, s.joint_jerk, s.joint_maxacc, self.model.max_joint_speed)

    def _step_position(self, dt: float) -> None:
        ex = self.executor
        was = ex.cmdnum
        if not ex.active:
            if self._state == STATE_MOVING:
                self._state = STATE_SLEEP
            return
        self.q = ex.step(dt, self.q, self._limits(), self.flange_target, self.tcp_matrix)
        self.counter += max(0, was - ex.cmdnum)
        if self._state != STATE_STOP:
            if ex.active and not (self._state == STATE_SUSPEND):
                self._state = STATE_MOVING
            elif not ex.active:
                self._state = STATE_SLEEP

    def advance(self, seconds: float) -> None:
        """Step for ``seconds`` of controller time (in-process clock)."""
        for _ in range(max(0, round(seconds / self.period))):
            self.step()

    # -- in-process API ------------------------------------------------------------------------
    def teach_move(self, q: Any) -> None:
        """Move the joints by hand (joint teaching mode 2), as a hand would."""
        if self.mode != MODE_JOINT_TEACH:
            raise RuntimeError("joints can be moved by hand only in joint teaching mode (mode 2)")
        arr = np.asarray(q, dtype=float)[: self.dof]
        if not np.all(np.isfinite(arr)) or not kin.within_limits(self.model, arr):
            raise ValueError("joint values outside the limits")
        self.q = arr.copy()

    # -- state changes -------------------------------------------------------------------------
    def system_reset(self) -> None:
        """The manual's "System reset" (section 2.1.1): motion ends, buffer cleared, state 5."""
        self.executor.clear()
        self.servo_target = None
        self.servo_tracker = None
        self._state = STATE_SYSTEM_RESET
        self._enter_stop()

    def _enter_stop(self) -> None:
        for c in self.components:
            on_stop = getattr(c, "on_stop", None)
            if on_stop is not None:
                on_stop()

    def _require_motion_allowed(self, servo: bool = False) -> None:
        """Refuse motion commands that cannot run now (reply bit 0x10; nothing is queued)."""
        if self.error_code or not self.ready:
            raise _NotReady()
        if servo and self.mode != MODE_SERVO:
            raise _NotReady()
        if not servo and self.mode != MODE_POSITION:
            raise _NotReady()

    def _queue(self, cmd: QueuedCommand) -> dict[str, Any]:
        if self.executor.cmdnum >= BUFFER_CAPACITY:
            raise CommandWarning(WARN_BUFFER_OVERFLOW)
        self.executor.buffer.append(cmd)
        if self._state == STATE_SLEEP:
            self._state = STATE_MOVING
        return {"cmdnum": self.executor.cmdnum}

    # -- handlers ------------------------------------------------------------------------------
    def _core_handlers(self) -> dict[int, Handler]:
        model = self.model
        h: dict[int, Handler] = {
            1: self._h_version,
            2: self._h_robot_sn,
            5: lambda v: {"tau_or_i": int(self.settings.report_current)},
            8: self._h_kinematics_params,
            10: self._h_shutdown,
            11: self._h_motion_enable,
            12: self._h_set_state,
            13: lambda v: {"state": self._state},
            14: lambda v: {"cmdnum": self.executor.cmdnum},
            15: lambda v: {"error": self.error_code, "warning": self.warning_code},
            16: self._h_clean_error,
            17: self._h_clean_warning,
            18: self._h_brake,
            19: self._h_set_mode,
            21: self._h_move_line,
            22: self._h_move_line,
            23: self._h_move_joint,
            24: self._h_register_24,
            25: self._h_move_home,
            26: self._h_dwell,
            27: self._h_move_circle,
            28: self._h_move_line,
            29: self._h_servoj,
            30: self._h_servo_cartesian,
            31: self._setter("tcp_jerk", "jerk", model.max_tcp_jerk),
            32: self._setter("tcp_maxacc", "maxacc", model.max_tcp_acc),
            33: self._setter("joint_jerk", "jerk", model.max_joint_jerk),
            34: self._setter("joint_maxacc", "maxacc", model.max_joint_acc),
            35: self._h_tcp_offset,
            36: self._h_tcp_load,
            37: self._h_collision_sensitivity,
            38: self._h_teach_sensitivity,
            39: self._h_clean_conf,
            40: self._h_save_conf,
            41: lambda v: {"pose": tuple(self.tcp_pose())},
            42: self._h_joint_states,
            43: self._h_ik,
            44: self._h_fk,
            45: self._h_joint_limit,
            51: self._h_gravity,
            52: self._h_boundary,
            55: lambda v: {"torques": self.joint_torques7()},
            59: self._h_boundary_on,
            70: self._h_report_tau_or_i,
            73: self._h_world_offset,
            76: self._h_pose_offset,
            77: self._h_self_collision,
            78: self._h_collision_tool,
            79: self._h_simulation_robot,
            91: self._h_pose_aa,
            92: self._h_move_line_aa,
            93: self._h_servo_cartesian_aa,
            106: self._h_servo_debug,
        }
        return h

    # version and identity
    def version_string(self) -> str:
        """Register 1: ``<axis>,<type>,<robot SN>,<box SN>,v1.6.0`` (research note section 5.1)."""
        return f"{self.model.axis},{self.model.robot_type},{self.robot_sn},{self.box_sn},{FIRMWARE_VERSION}"

    def _h_version(self, v: Values) -> dict[str, Any]:
        return {"version": self.version_string()}

    def _h_robot_sn(self, v: Values) -> dict[str, Any]:
        return {"serials": f"{self.robot_sn}\0{self.box_sn}\0".encode("ascii").ljust(40, b"\0")[:40]}

    def _h_kinematics_params(self, v: Values) -> dict[str, Any]:
        params: list[float] = []
        for j in self.model.joints:
            params += [j.origin_xyz[0] / 1000.0, j.origin_xyz[1] / 1000.0, j.origin_xyz[2] / 1000.0,
                       *j.origin_rpy]
        params += [0.0] * (42 - len(params))
        return {"valid": 1, "dof": self.dof, "robot_type": self.model.robot_type, "params": tuple(params)}

    def _h_shutdown(self, v: Values) -> dict[str, Any]:
        # Remote shutdown of the control box OS: the emulator acknowledges and keeps running
        # (documented in the README); the server may act on ``shutdown_requested``.
        self.shutdown_requested = True
        return {"cmdnum": self.executor.cmdnum}

    # state machine
    def _joint_ids(self, joint: int) -> list[int]:
        if joint == 8:
            return list(range(self.dof))
        if 1 <= joint <= self.dof:
            return [joint - 1]
        raise ParameterError(f"joint {joint} out of range")

    def _h_motion_enable(self, v: Values) -> None:
        ids = self._joint_ids(v["joint"])
        if v["enable"] not in (0, 1):
            raise ParameterError("enable must be 0 or 1")
        for i in ids:
            self.enabled[i] = bool(v["enable"])
            if v["enable"]:
                self.brakes[i] = True
        self.system_reset()
        return None

    def _h_brake(self, v: Values) -> None:
        ids = self._joint_ids(v["joint"])
        for i in ids:
            self.brakes[i] = not bool(v["enable"])
        self.system_reset()
        return None

    def _h_set_state(self, v: Values) -> None:
        s = v["state"]
        if s == 0:
            if self.error_code:
                return None  # stays in stop; the reply carries 0x40
            if self._state == STATE_SUSPEND:
                self.executor.ramp_to(1.0, self._limits())
                self._state = STATE_MOVING if self.executor.active else STATE_SLEEP
            elif self._state in (STATE_STOP, STATE_SYSTEM_RESET):
                if not self.executor.stopping:
                    self._state = STATE_SLEEP
            return None
        if s == STATE_SUSPEND:
            if self._state in (STATE_MOVING, STATE_SLEEP):
                self.executor.ramp_to(0.0, self._limits())
                self._state = STATE_SUSPEND
            return None
        if s == STATE_STOP:
            if self.mode == MODE_POSITION and self.executor.plan is not None:
                self.executor.buffer.clear()
                self.executor.stopping = True
                self.executor.ramp_to(0.0, self._limits())
            else:
                self.executor.clear()
            self.servo_target = None
            self._state = STATE_STOP
            self._enter_stop()
            return None
        raise ParameterError(f"state {s} cannot be set")

    def _h_clean_error(self, v: Values) -> None:
        if self.error_code in _REENABLE_ERRORS:
            self.enabled = [False] * self.dof
        self.error_code = 0
        self.servo_errors = [0] * self.dof
        self.system_reset()
        return None

    def _h_clean_warning(self, v: Values) -> None:
        self.warning_code = 0
        return None

    def _h_set_mode(self, v: Values) -> None:
        mode = v["mode"]
        if mode not in (MODE_POSITION, MODE_SERVO, MODE_JOINT_TEACH):
            raise ParameterError(f"mode {mode} not available")
        self.mode = mode
        self.system_reset()
        return None

    # motion commands
    def _check_speed(self, speed: float, acc: float, vmax: float, amax: float) -> None:
        if not (in_range(speed, vmax) and speed > 0.0 and in_range(acc, amax) and acc > 0.0):
            raise ParameterError("speed or acceleration outside Table 1.2")

    def _h_move_line(self, v: Values) -> dict[str, Any]:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self._check_speed(v["speed"], v["acc"], self.model.max_tcp_speed, self.model.max_tcp_acc)
        self._require_motion_allowed()
        code = self._current_code
        radius = float(v.get("radius", -1.0))
        cmd = LineMove(code, tuple(v["pose"]), v["speed"], v["acc"], radius=radius, tool_frame=(code == 28),
                       relative=(code == 28))
        return self._queue(cmd)

    def _h_move_line_aa(self, v: Values) -> dict[str, Any]:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self._check_speed(v["speed"], v["acc"], self.model.max_tcp_speed, self.model.max_tcp_acc)
        if v["coord"] not in (0, 1) or v["relative"] not in (0, 1):
            raise ParameterError("coordinate and relative flags are 0 or 1")
        self._require_motion_allowed()
        cmd = LineMove(92, tuple(v["pose"]), v["speed"], v["acc"], tool_frame=bool(v["coord"]),
                       relative=bool(v["relative"]) or bool(v["coord"]), axis_angle=True)
        return self._queue(cmd)

    def _joint_target(self, joints: tuple[float, ...]) -> np.ndarray:
        q = np.asarray(joints[: self.dof], dtype=float)
        if not kin.within_limits(self.model, q):
            raise CommandError(C_JOINT_LIMIT, "joint target outside the limits")
        return q

    def _h_move_joint(self, v: Values) -> dict[str, Any]:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self._check_speed(v["speed"], v["acc"], self.model.max_joint_speed, self.model.max_joint_acc)
        self._require_motion_allowed()
        q = self._joint_target(v["joints"])
        return self._queue(JointMove(self._current_code, q, v["speed"], v["acc"]))

    def _h_register_24(self, v: Values) -> dict[str, Any] | None:
        # Manual: register 24 selects torque or current in reports (1 byte). The SDK, for
        # firmware >= 1.5.20, sends a joint move with a blend radius on 24 (10 fp32).
        if "joints" in v:
            v2 = dict(v)
            return self._h_move_joint(v2)
        return self._h_report_tau_or_i(v)

    def _h_move_home(self, v: Values) -> dict[str, Any]:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self._check_speed(v["speed"], v["acc"], self.model.max_joint_speed, self.model.max_joint_acc)
        self._require_motion_allowed()
        return self._queue(JointMove(25, np.zeros(self.dof), v["speed"], v["acc"]))

    def _h_dwell(self, v: Values) -> dict[str, Any]:
        t = v["seconds"]
        if not (math.isfinite(t) and t >= 0.0):
            raise ParameterError("pause time must be >= 0")
        self._require_motion_allowed()
        return self._queue(Dwell(26, t))

    def _h_move_circle(self, v: Values) -> dict[str, Any]:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self._check_speed(v["speed"], v["acc"], self.model.max_tcp_speed, self.model.max_tcp_acc)
        if v["percent"] <= 0.0:
            raise ParameterError("percent must be > 0")
        self._require_motion_allowed()
        return self._queue(CircleMove(27, tuple(v["pose1"]), tuple(v["pose2"]), v["speed"], v["acc"],
                                      v["percent"]))

    def _h_servoj(self, v: Values) -> None:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self._require_motion_allowed(servo=True)
        self.servo_target = self._joint_target(v["joints"])
        return None

    def _tracker(self) -> motion.ServoTracker:
        if self.servo_tracker is None:
            m = self.model
            self.servo_tracker = motion.ServoTracker(self.q, m.max_joint_speed, m.max_joint_acc)
        return self.servo_tracker

    def _servo_cartesian(self, T: np.ndarray) -> None:
        q = kin.ik(self.model, self.flange_target(T), self.q, limited=False)
        if q is None:
            raise CommandWarning(WARN_NO_SOLUTION)
        if not kin.within_limits(self.model, q):
            raise CommandError(C_JOINT_LIMIT)
        self.servo_target = q

    def _h_servo_cartesian(self, v: Values) -> None:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self._require_motion_allowed(servo=True)
        T = wire_pose_to_matrix(v["pose"])
        if v["coord"] != 0.0:
            T = self.tcp_matrix() @ T
        self._servo_cartesian(T)
        return None

    def _h_servo_cartesian_aa(self, v: Values) -> None:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self._require_motion_allowed(servo=True)
        T = rot.pose_aa_to_matrix(np.asarray(v["pose"], dtype=float))
        start = self.tcp_matrix()
        if v["coord"] != 0.0:
            T = start @ T
        elif int(v.get("relative", 0)) == 1:
            out = np.eye(4)
            out[:3, :3] = T[:3, :3] @ start[:3, :3]
            out[:3, 3] = start[:3, 3] + T[:3, 3]
            T = out
        self._servo_cartesian(T)
        return None

    # parameters
    def _setter(self, name: str, key: str, hi: float) -> Handler:
        def set_value(v: Values) -> dict[str, Any]:
            value = v[key]
            if not in_range(value, hi):
                raise ParameterError(f"{name} outside Table 1.2")
            setattr(self.settings, name, float(value))
            return {"cmdnum": self.executor.cmdnum}

        return set_value

    def _h_tcp_offset(self, v: Values) -> None:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self.settings.tcp_offset = [float(x) for x in v["pose"]]
        self.system_reset()
        return None

    def _h_tcp_load(self, v: Values) -> None:
        if not all_finite(v) or v["mass"] < 0.0:
            raise ParameterError("bad payload")
        self.settings.tcp_load = [float(v["mass"]), *(float(x) for x in v["center"])]
        return None

    def _h_collision_sensitivity(self, v: Values) -> None:
        lo, hi = COLLISION_SENSITIVITY_RANGE
        if not lo <= v["sensitivity"] <= hi:
            raise ParameterError("collision sensitivity is 0..5")
        self.settings.collision_sensitivity = int(v["sensitivity"])
        self.system_reset()
        return None

    def _h_teach_sensitivity(self, v: Values) -> None:
        lo, hi = TEACH_SENSITIVITY_RANGE
        if not lo <= v["sensitivity"] <= hi:
            raise ParameterError("teach sensitivity is 1..5")
        self.settings.teach_sensitivity = int(v["sensitivity"])
        self.system_reset()
        return None

    def _h_clean_conf(self, v: Values) -> None:
        self.settings = Settings.for_model(self.model)
        if self.on_clean_conf is not None:
            self.on_clean_conf()
        return None

    def _h_save_conf(self, v: Values) -> None:
        if self.on_save is not None:
            self.on_save(self.config_values())
        return None

    def config_values(self) -> dict[str, Any]:
        return self.settings.to_dict()

    def load_config(self, data: dict[str, Any]) -> None:
        self.settings = Settings.from_dict(data, self.model)
        tool = self.settings.collision_tool
        try:
            self.collision_tool = collision.tool_model(int(tool[0]), tool[1:7])
        except (ValueError, TypeError, IndexError):
            self.collision_tool = collision.NO_TOOL

    def _h_joint_states(self, v: Values) -> dict[str, Any]:
        """Register 42: joint positions; SDKs asking ``num`` blocks also get velocities and efforts."""
        out: dict[str, Any] = {"joints": self.joints7()}
        blocks = int(v.get("num", 1)) & 0x0F
        if blocks >= 2:
            out["velocities"] = self.joints7(self.qd)
        if blocks >= 3:
            out["efforts"] = self.joint_torques7()
        return out

    # kinematics registers (issue 3)
    def _h_ik(self, v: Values) -> dict[str, Any]:
        if not all_finite(v):
            raise ParameterError("non-finite pose")
        T = wire_pose_to_matrix(v["pose"])
        q = kin.ik(self.model, self.flange_target(T), self.q, restarts=True)
        if q is None:
            raise CommandWarning(WARN_NO_SOLUTION)
        return {"joints": self.joints7(q)}

    def _h_fk(self, v: Values) -> dict[str, Any]:
        if not all_finite(v):
            raise ParameterError("non-finite joints")
        q = np.asarray(v["joints"][: self.dof], dtype=float)
        return {"pose": tuple(rot.matrix_to_pose(self.tcp_matrix(q)))}

    def _h_joint_limit(self, v: Values) -> dict[str, Any]:
        q = np.asarray(v["joints"][: self.dof], dtype=float)
        ok = bool(np.all(np.isfinite(q))) and kin.within_limits(self.model, q)
        return {"limited": 0 if ok else 1}

    def _h_pose_offset(self, v: Values) -> dict[str, Any]:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        aa_in = int(v["input_aa"]) == 1
        aa_out = int(v["output_aa"]) == 1
        to_m = rot.pose_aa_to_matrix if aa_in else wire_pose_to_matrix
        T1 = to_m(np.asarray(v["pose1"], dtype=float))
        T2 = to_m(np.asarray(v["pose2"], dtype=float))
        D = kin.pose_offset(T1, T2)
        out = rot.matrix_to_pose_aa(D) if aa_out else rot.matrix_to_pose(D)
        return {"pose": tuple(out)}

    def _h_pose_aa(self, v: Values) -> dict[str, Any]:
        return {"pose": tuple(rot.matrix_to_pose_aa(self.tcp_matrix()))}

    def _h_world_offset(self, v: Values) -> None:
        if not all_finite(v):
            raise ParameterError("non-finite value")
        self.settings.world_offset = [float(x) for x in v["pose"]]
        self.system_reset()
        return None

    # other settings
    def _h_gravity(self, v: Values) -> None:
        g = np.asarray(v["direction"], dtype=float)
        if not np.all(np.isfinite(g)) or float(np.linalg.norm(g)) == 0.0:
            raise ParameterError("gravity direction must be a non-zero finite vector")
        self.settings.gravity_direction = [float(x) for x in g]
        return None

    def _h_boundary(self, v: Values) -> None:
        b = [int(x) for x in v["boundary"]]
        if b[0] < b[1] or b[2] < b[3] or b[4] < b[5]:
            raise ParameterError("boundary maxima must not be below minima")
        self.settings.boundary = b
        return None

    def _h_boundary_on(self, v: Values) -> None:
        if v["on"] not in (0, 1):
            raise ParameterError("switch is 0 or 1")
        self.settings.boundary_on = bool(v["on"])
        return None

    def _h_report_tau_or_i(self, v: Values) -> dict[str, Any] | None:
        value = v["tau_or_i"]
        if value not in (0, 1):
            raise ParameterError("0: torque, 1: current")
        self.settings.report_current = bool(value)
        return None

    def _h_self_collision(self, v: Values) -> None:
        if v["on"] not in (0, 1):
            raise ParameterError("switch is 0 or 1")
        self.settings.self_collision_on = bool(v["on"])
        return None

    def _h_collision_tool(self, v: Values) -> None:
        """Register 78: the end tool's geometry for self-collision detection (model/collision.py)."""
        params = [float(x) for x in v.get("params", ())]
        try:
            tool = collision.tool_model(int(v["tool_type"]), params)
        except ValueError as exc:
            raise ParameterError(str(exc)) from exc
        self.collision_tool = tool
        self.settings.collision_tool = [float(tool.kind), *params, *([0.0] * (6 - len(params)))][:7]
        return None

    def _h_simulation_robot(self, v: Values) -> None:
        """Register 79, virtual robot mode: while on, the reported arm follows the commands and the
        physical arm stays where it was; switching it off ends motion and reports the physical arm
        again."""
        if v["on"] not in (0, 1):
            raise ParameterError("switch is 0 or 1")
        on = bool(v["on"])
        if on and not self.simulation_robot:
            self._physical_q = self.q.copy()
        elif not on and self.simulation_robot:
            self.executor.clear()
            self.servo_target = None
            self.servo_tracker = None
            if self._physical_q is not None:
                self.q = self._physical_q
            self._physical_q = None
            if self._state in (STATE_MOVING, STATE_SUSPEND):
                self._state = STATE_SLEEP
        self.simulation_robot = on
        return None

    @property
    def physical_joints(self) -> np.ndarray:
        """Joints of the physical arm: frozen while virtual robot mode (register 79) is on."""
        return self._physical_q.copy() if self._physical_q is not None else self.q.copy()

    def _h_servo_debug(self, v: Values) -> dict[str, Any]:
        """Register 106: (state, error code) of joints 1-7, then of the end tool (gripper)."""
        servos = [0] * 16
        for i in range(self.dof):
            servos[2 * i] = 1 if self.servo_errors[i] else 0
            servos[2 * i + 1] = self.servo_errors[i] & 0xFF
        servos[14], servos[15] = self.tool_error
        return {"servos": tuple(servos)}

    # torques (issue 7 provides the dynamic model)
    def joint_torques(self) -> np.ndarray:
        """Theoretical joint torques (N m): gravity of the links and the payload of register 36
        with the gravity direction of register 51, plus the inertial terms of the planned motion
        (recursive Newton-Euler, :mod:`xarm_emu.model.dynamics`). Computed at most once per step."""
        if self._torque_cache is not None and self._torque_cache[0] == self.steps:
            return self._torque_cache[1]
        s = self.settings
        try:
            g: Any = dyn.gravity_from_direction(s.gravity_direction)
        except ValueError:
            g = dyn.DEFAULT_GRAVITY
        tau = dyn.inverse_dynamics(self.model, self.q, self.qd, self.qdd, g, s.tcp_load[0], s.tcp_load[1:4])
        self._torque_cache = (self.steps, tau)
        return tau

    def joint_currents(self) -> np.ndarray:
        """Motor currents (A) from the torques and the documented torque constants."""
        return dyn.torques_to_currents(self.model, self.joint_torques())

    def reported_torques(self) -> np.ndarray:
        """What the reports and register 55 carry: torques, or currents after registers 24/70."""
        return self.joint_currents() if self.settings.report_current else self.joint_torques()

    def joint_torques7(self) -> tuple[float, ...]:
        t = self.reported_torques()
        return tuple(float(x) for x in t) + (0.0,) * (7 - self.dof)

    @property
    def _current_code(self) -> int:
        return self._code


class _NotReady(CommandWarning):
    """A motion command while the arm cannot move: nothing queued, the reply shows 0x10."""

    def __init__(self) -> None:
        super().__init__(0, "arm not ready for motion")
