"""The :class:`Controller`, which assembles the rooms: readiness, poses, dispatch through the
binding table, the control step and the safety checks, over the state of ``core/``. Handlers, devices
and applications see it through the protocol of ``core/controller_protocol.py``.

Pure and deterministic: no sockets, no wall clock. The server calls :meth:`handle` for every
request and :meth:`step` once per control period (:data:`~xarm_emu.controller.core.interface.PERIOD`).
Register handlers are plain functions in :mod:`.handlers`, bound in one table; the mutable state is
one :class:`~.core.controller_state.ControllerState` (:attr:`Controller.data`), beside the constant
robot model and the :class:`~.core.settings.Settings`.

States (register 13, manual section 2.1.3): 1 in motion, 2 sleep (idle and ready), 3 suspend,
4 stop, 5 system reset. Modes (register 19): 0 position, 1 servo, 2 joint teaching, 3 Cartesian
teaching (not available).

Speed: the end of :meth:`Controller.step` computes the joint speeds ``qd = (q - q_prev) / dt`` and
accelerations ``qdd = (qd - qd_prev) / dt`` with two shortcuts that change no value
(``tests/test_period_paths.py``), each measured as CPU time of one period of an xArm6, best of 45,
against the same code without it: ``dt`` is divided as an array of the period once per joint (numpy
divides by an array faster than by a Python float: a joint move's period 6.5 us against 7.0 us), and
a period that leaves the joints alone after one that ended with them exactly +0 keeps those very
arrays (:meth:`Controller._known_still`; a period at rest stepped in full 1.7 us against 3.3 us).
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from ..model import collision
from ..model import dynamics as dyn
from ..model import kinematics as kin
from ..model import rotations as rot
from ..model.robots import RobotModel
from ..protocol import registers as regs
from ..protocol.firmware import DEFAULT_PROFILE, FirmwareProfile
from ..protocol.frame import STATE_ERROR, STATE_FAILED, STATE_NOT_READY, STATE_WARNING
from ..protocol.layouts import LayoutError, all_within
from . import handlers, motion
from .applications import force_control, reduced
from .applications.modes import EVERY_STEP, EVERY_STEP_IDLE, MODE_STEPS
from .core import controller_protocol, safety
from .core.commands import QueuedCommand
from .core.controller_protocol import Component
from .core.controller_state import ControllerState, StateField
from .core.executor import Executor, Limits
from .core.faults import Faults
from .core.interface import (
    C_OTHER,
    C_PLANNING,
    PARAMETER_LIMIT,
    PERIOD,
    WARN_BUFFER_OVERFLOW,
    WARN_PARAMETER,
    WARN_UNKNOWN_COMMAND,
    CommandError,
    CommandFailed,
    CommandWarning,
    Handler,
    Hooks,
    NotReady,
    ParameterError,
    bind_component,
)
from .core.settings import Settings
from .core.state_machine import (
    MODE_JOINT_TEACH,
    MODE_POSITION,
    MODE_SERVO,
    STATE_MOVING,
    STATE_SLEEP,
    STATE_STOP,
    STATE_SUSPEND,
    Event,
    fire,
)
from .devices import ft_sensor

#: Command buffer capacity; the SDK throttles itself at 512 (max_cmdnum).
BUFFER_CAPACITY = 1024

log = logging.getLogger("xarm_emu.controller")

#: The states in which position mode runs the command buffer, and servo mode follows its target.
_POSITION_STATES = frozenset((STATE_MOVING, STATE_SLEEP, STATE_SUSPEND))
_SERVO_STATES = frozenset((STATE_SLEEP, STATE_MOVING))
#: The offsets (registers 35, 73) that change no pose, and the dtype of a pose that needs no
#: conversion, for :meth:`Controller.flange_target`'s usual case.
_NO_OFFSET = [0.0] * 6
_FLOAT64 = np.dtype(np.float64)
#: The events of a position-mode period (an enum member read from its class costs a lookup).
_IDLE, _PLAN_RUNNING, _PLAN_FINISHED = Event.IDLE, Event.PLAN_RUNNING, Event.PLAN_FINISHED


def version_string(model: RobotModel, robot_sn: str, box_sn: str,
                   firmware: FirmwareProfile = DEFAULT_PROFILE) -> str:
    """Register 1: ``<axis>,<type>,<robot SN>,<box SN>,v<firmware version>``."""
    return f"{model.axis},{model.robot_type},{robot_sn},{box_sn},v{firmware.version}"


def joint_torques(model: RobotModel, data: ControllerState, settings: Settings) -> np.ndarray:
    """Theoretical joint torques (N m) of state ``data``: gravity of the links and the payload of
    register 36 with the gravity direction of register 51, plus the inertial terms of the planned
    motion (recursive Newton-Euler, :mod:`xarm_emu.model.dynamics`), plus a calibrated model's offsets
    and friction (``dynamics.joint_friction``)."""
    s = settings
    tau = dyn.inverse_dynamics(model, data.q, data.qd, data.qdd, _gravity(s), s.tcp_load[0], s.tcp_load[1:4])
    friction = dyn.joint_friction(model, data.qd) if model.calibration is not None else None
    return tau if friction is None else tau + friction


def joint_torques_many(model: RobotModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                       settings: Settings) -> np.ndarray:
    """:func:`joint_torques` of ``N`` states at once (``(N, dof)`` joints, speeds and accelerations)
    under one payload and gravity direction: ``(N, dof)`` torques."""
    s = settings
    tau = dyn.inverse_dynamics_many(model, q, qd, qdd, _gravity(s), s.tcp_load[0], s.tcp_load[1:4])
    friction = dyn.joint_friction(model, qd) if model.calibration is not None else None
    return tau if friction is None else tau + friction


def _gravity(settings: Settings) -> Any:
    """The gravity vector of register 51's direction (the default when it has no usable length)."""
    try:
        return dyn.gravity_from_direction(settings.gravity_direction)
    except ValueError:
        return dyn.DEFAULT_GRAVITY


def tcp_matrix(model: RobotModel, q: np.ndarray, settings: Settings) -> np.ndarray:
    """TCP pose (4x4, mm) of joints ``q`` in the user frame, TCP offset applied (registers 35, 73)."""
    return kin.tcp_pose(model, q, settings.tcp_offset, settings.world_offset)


class Controller:
    """One emulated control box with its arm: dispatch, readiness, poses and the control step over
    one :class:`~.core.controller_state.ControllerState`."""

    def __init__(self, model: RobotModel, *, robot_sn: str = "XI1300", box_sn: str = "AC1300",
                 period: float = PERIOD, firmware: FirmwareProfile = DEFAULT_PROFILE) -> None:
        self.model = model
        #: The firmware this box claims, and the register table such a box answers.
        self.firmware = firmware
        self.registers = regs.registers_for(firmware)
        self._float_checked = regs.float_checked(self.registers)
        self._inf_unchanged = regs.inf_unchanged(self.registers)
        self._per_joint = regs.per_joint_fields(self.registers)
        self.dof = model.dof
        self.period = period
        self.robot_sn = robot_sn
        self.box_sn = box_sn
        #: Every mutable value of the box (:class:`~.core.controller_state.ControllerState`).
        self.data = ControllerState.initial(self.dof)
        self.settings = Settings.for_model(self.model)
        #: Calls outside the controller; the emulator wires them up.
        self.hooks = Hooks()
        self.executor = Executor(model, self.data.motion)
        self.components: list[Component] = []
        self._torque_cache: tuple[tuple[Any, ...], np.ndarray] | None = None
        self._pose_cache: tuple[tuple[Any, ...], np.ndarray] | None = None
        self._limits_cache: tuple[tuple[float, ...], Limits] | None = None
        #: The control period once per joint: numpy divides an array by it faster than by a float,
        #: to the same values (the joint speeds and accelerations of :meth:`step`).
        self._period_per_joint = np.full(self.dof, period)
        #: The bytes of a joint vector of +0.0 (speeds and accelerations at rest, :meth:`_still`).
        self._zeros = bytes(8 * self.dof)
        #: The speed and acceleration arrays of the last period when it left the joints alone and
        #: ended :meth:`_still` (see :meth:`_known_still`).
        self._still_rates: tuple[np.ndarray, np.ndarray] | None = None
        #: Handlers by register code, and the modes that route a code elsewhere (code -> mode ->
        #: handler): the rows of the one binding table (:data:`.handlers.TABLE`) this box answers.
        self._handlers: dict[int, Handler]
        self._routes: dict[int, dict[int, Handler]]
        self._handlers, self._routes = self.register_handlers()
        #: Tests set this: unexpected exceptions in handlers or steps propagate instead of being
        #: logged and answered with warning 12 / error C29 (what a running server does).
        self.strict = False

    def register_handlers(self) -> tuple[dict[int, Handler], dict[int, dict[int, Handler]]]:
        """Handlers and mode routes by register code: the controller's rows of the binding table
        (:data:`.handlers.TABLE`), bound to this controller."""
        return handlers.bind(self)

    def adopt(self, data: ControllerState, settings: Settings) -> None:
        """Take ``data`` and ``settings`` as the box's state (a restored checkpoint); derived
        values are computed afresh."""
        self.data = data
        self.settings = settings
        self.executor.data = data.motion
        self._torque_cache = self._pose_cache = self._limits_cache = self._still_rates = None

    # -- the state's values (ControllerState), by the names the handlers and components use ---
    #: Motion state (register 13); only :func:`.core.state_machine.fire` changes it.
    motion_state = StateField[int]()
    steps = StateField[int]()
    q = StateField[np.ndarray]()
    qd = StateField[np.ndarray]()
    qdd = StateField[np.ndarray]()
    mode = StateField[int]()  # register 19
    enabled = StateField[list[bool]]()  # register 11
    brakes = StateField[list[bool]]()  # register 18; True: brake released
    faults = StateField[Faults]()  # chapter 3
    servo_target = StateField[np.ndarray | None]()
    servo_tracker = StateField[motion.ServoTracker | None]()
    simulation_robot = StateField[bool]()  # register 79
    collision_tool = StateField[collision.ToolModel]()  # register 78
    user_counter = StateField[int]()  # registers 74/75 (rich report bytes 285-288)

    # -- saved configuration (registers 39/40) --------------------------------------------------
    def config_values(self) -> dict[str, Any]:
        """The settings register 40 saves."""
        values = self.settings.to_dict()
        if (saved := reduced.config_of(self)) is not None:
            values[reduced.CONFIG_KEY] = saved
        if (ft_saved := ft_sensor.config_of(self)) is not None:
            values[ft_sensor.CONFIG_KEY] = ft_saved
        return values

    def load_config(self, data: dict[str, Any]) -> None:
        """Apply saved settings (invalid entries keep their defaults) and the collision tool."""
        self.settings = Settings.from_dict(data, self.model)
        reduced.load_config(self, data.get(reduced.CONFIG_KEY))
        ft_sensor.load_config(self, data.get(ft_sensor.CONFIG_KEY))
        tool = self.settings.collision_tool
        try:
            self.collision_tool = collision.tool_model(int(tool[0]), tool[1:7])
        except (ValueError, TypeError, IndexError):
            self.collision_tool = collision.NO_TOOL

    @property
    def physical_joints(self) -> np.ndarray:
        """Joints of the physical arm: frozen while virtual robot mode (register 79) is on."""
        d = self.data
        return d.physical_q.copy() if d.physical_q is not None else d.q.copy()

    # -- faults (chapter 3) ----------------------------------------------------------------------
    @property
    def error_code(self) -> int:
        return self.data.faults.error

    @error_code.setter
    def error_code(self, code: int) -> None:
        self.data.faults.error = code

    @property
    def warning_code(self) -> int:
        return self.data.faults.warning

    @warning_code.setter
    def warning_code(self, code: int) -> None:
        self.data.faults.warning = code

    @property
    def servo_errors(self) -> list[int]:
        """Per-joint servo error codes (section 3.1)."""
        return self.data.faults.servo_errors

    @servo_errors.setter
    def servo_errors(self, codes: list[int]) -> None:
        self.data.faults.servo_errors = codes

    @property
    def handler_codes(self) -> frozenset[int]:
        """Register codes with a handler, the controller's and its components'."""
        return frozenset(self._handlers)

    def handler_of(self, code: int) -> Handler:
        """The handler bound to register ``code`` (KeyError when none is)."""
        return self._handlers[code]

    def version_string(self) -> str:
        """Register 1's version string of this control box."""
        return version_string(self.model, self.robot_sn, self.box_sn, self.firmware)

    # -- components ----------------------------------------------------------------------------
    def add_component(self, component: Component) -> None:
        """Plug in a component: it steps with the controller, and its handlers answer the registers
        of this box's firmware (a register its table lacks stays unknown, warning 13)."""
        bound = bind_component(component, handlers.TABLE.values())
        for code in bound.keys() & self._handlers.keys():
            raise ValueError(f"register {code} of {type(component).__name__} is bound already")
        self.components.append(component)
        self._handlers.update({code: h for code, h in bound.items() if code in self.registers})

    # -- ControllerView ------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return self.data.time

    @property
    def state(self) -> int:
        return self.data.motion_state

    @property
    def is_moving(self) -> bool:
        return self.data.motion_state == STATE_MOVING

    @property
    def tcp_position(self) -> tuple[float, float, float]:
        p = self.tcp_matrix()[:3, 3]
        return (float(p[0]), float(p[1]), float(p[2]))

    def raise_error(self, code: int) -> None:
        """Enter an error: stop at once, discard the buffer, state 4 (section 3.2.1)."""
        d = self.data
        d.faults.error = code
        self.executor.discard()
        d.servo_target = None
        d.qd[:] = 0.0
        fire(self, Event.ERROR)
        self.enter_stop()

    def raise_warning(self, code: int) -> None:
        """Set a warning: only the flag and the code change (section 3.2.2)."""
        self.data.faults.warning = code

    # -- readiness -----------------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        """Whether the arm can perform motion (reply bit 0x10 clear)."""
        d = self.data
        return (d.faults.error == 0 and d.motion_state in (STATE_MOVING, STATE_SLEEP, STATE_SUSPEND)
                and all(d.enabled) and all(d.brakes))

    def status_byte(self) -> int:
        s = 0
        f = self.data.faults
        if f.error:
            s |= STATE_ERROR
        if f.warning:
            s |= STATE_WARNING
        if not self.ready:
            s |= STATE_NOT_READY
        return s

    # -- poses ---------------------------------------------------------------------------------
    def tcp_matrix(self, q: np.ndarray | None = None) -> np.ndarray:
        """TCP pose (4x4, mm) in the user frame, TCP offset applied."""
        if q is None:
            q_now = self.data.q
            key = (q_now.tobytes(), tuple(self.settings.tcp_offset), tuple(self.settings.world_offset))
            if self._pose_cache is not None and self._pose_cache[0] == key:
                return self._pose_cache[1]
            T = tcp_matrix(self.model, q_now, self.settings)
            self._pose_cache = (key, T)
            return T
        return tcp_matrix(self.model, q, self.settings)

    def tcp_pose(self) -> np.ndarray:
        """(x, y, z, roll, pitch, yaw) of the TCP in the user frame (register 41)."""
        return rot.matrix_to_pose(self.tcp_matrix())

    def flange_target(self, T_tcp_user: np.ndarray) -> np.ndarray:
        """Flange pose (4x4, base frame) that puts the TCP at ``T_tcp_user`` (registers 35, 73)."""
        s = self.settings
        tcp, world = s.tcp_offset, s.world_offset
        if (type(T_tcp_user) is np.ndarray and T_tcp_user.dtype is _FLOAT64 and type(tcp) is list
                and tcp == _NO_OFFSET and type(world) is list and world == _NO_OFFSET):
            return T_tcp_user  # no offsets: the pose itself (what kin.flange_target returns then)
        return kin.flange_target(T_tcp_user, tcp, world)

    def joints7(self, q: np.ndarray | None = None) -> tuple[float, ...]:
        v = self.q if q is None else q
        return tuple(float(x) for x in v) + (0.0,) * (7 - self.dof)

    # -- request handling ----------------------------------------------------------------------
    def handle(self, code: int, params: bytes) -> tuple[int, bytes]:
        """Handle one command; returns (reply state byte, reply parameter bytes)."""
        reg = self.registers.get(code)
        routes = self._routes.get(code)
        handler = (routes.get(self.data.mode) if routes else None) or self._handlers.get(code)
        if reg is None or handler is None:
            log.info("register %d is unknown to firmware %s: warning 13", code, self.firmware)
            self.raise_warning(WARN_UNKNOWN_COMMAND)
            return self.status_byte(), b""
        reply = b""
        extra = 0
        try:
            try:
                values = reg.request.decode(params)
            except LayoutError as exc:
                raise ParameterError(str(exc)) from exc
            if code in self._per_joint:
                values = _unread_axes_cleared(values, self._per_joint[code], self.dof)
            if code in self._float_checked and not all_within(
                    values, PARAMETER_LIMIT, inf_unchanged=code in self._inf_unchanged):
                raise ParameterError(f"a float parameter is not finite or exceeds {PARAMETER_LIMIT:g}")
            result = handler(values)
            if result is not None:
                reply = reg.reply.encode(result)
        except CommandFailed as exc:
            log.info("register %d could not be carried out: %s", code, exc)
            extra = STATE_FAILED
            reply = self._default_reply(reg)
        except NotReady:
            extra = STATE_NOT_READY  # this command cannot run now: nothing queued, nothing moves
            reply = self._default_reply(reg)
        except CommandWarning as w:
            self.raise_warning(w.code)
            reply = self._default_reply(reg)
        except CommandError as e:
            self.raise_error(e.code)
            reply = self._default_reply(reg)
        except Exception:  # a bug must not take the connection down: log it, answer warning 12
            if self.strict:
                raise
            log.exception("register %d with %d parameter bytes failed", code, len(params))
            self.raise_warning(WARN_PARAMETER)
            reply = self._default_reply(reg)
        return self.status_byte() | extra, reply

    def _default_reply(self, reg: regs.Register) -> bytes:
        """Reply bytes of a refused command: the buffer count for queued commands, else zeros.

        The SDK raises on short replies, so a refused getter still
        answers with its full layout.
        """
        if reg.reply.fields and reg.reply.fields[0].name == "cmdnum" and len(reg.reply.fields) == 1:
            return reg.reply.encode(cmdnum=self.executor.cmdnum)
        return bytes(reg.reply.size)

    # -- stepping ------------------------------------------------------------------------------
    def step(self) -> None:
        """Advance the control box by one control period."""
        dt = self.period
        d = self.data
        d.time += dt
        d.steps += 1
        q_prev = d.q
        try:
            if d.faults.error == 0:
                state = d.motion_state
                mode = d.mode
                if mode == MODE_POSITION and state in _POSITION_STATES:
                    if not force_control.period(self, dt, _ft_control_wrench):  # register 202
                        self._step_position(dt)
                elif mode == MODE_SERVO and d.servo_target is not None and state in _SERVO_STATES:
                    tracker = self._tracker()
                    tracker.set_target(d.servo_target)
                    q, _, _ = tracker.step(dt)
                    d.q = q.copy()
                    fire(d, Event.SERVO_AT_TARGET if tracker.at_target else Event.SERVO_MOVING)
                elif state == STATE_STOP and d.motion.stopping:
                    self._step_position(dt)
                elif (mode_step := MODE_STEPS.get(mode)) is not None:
                    mode_step(self, dt)
                if d.q is not q_prev:
                    self._check_safety(q_prev)
        except CommandError as e:
            self.raise_error(e.code)
        except motion.PlanningError:
            log.warning("no trajectory for command %r", self.executor.current)
            self.raise_error(C_PLANNING)
        except Exception:  # keep the control loop alive; the arm stops with C29 "other errors"
            if self.strict:
                raise
            log.exception("control step failed")
            self.raise_error(C_OTHER)
        if d.q is not q_prev or not self._known_still():  # else they are +0 again, as they are
            # the joint speeds and accelerations of the period: qd = (q - q_prev) / dt, qdd likewise
            qd = (d.q - q_prev) / self._period_per_joint
            d.qd, d.qdd = qd, (qd - d.qd) / self._period_per_joint
            self._still_rates = (d.qd, d.qdd) if d.q is q_prev and self._still() else None
        for c in self.components:
            c.step(dt, self)
        for hook in EVERY_STEP:
            hook(self, dt)

    def at_rest(self, settled: bool = False) -> bool:
        """Whether a control period now would change nothing of the controller but its clock (time
        and period count): the joints rest (speeds and accelerations exactly +0), no motion runs or
        is due in the present state and mode (the branches of :meth:`step`), and every per-period
        hook is idle. Components answer for themselves (:func:`~.core.interface.idle_until`).

        Servo mode holding its target counts only when ``settled`` (the caller knows that nothing
        has changed the box since the last period ran in full): its period re-checks the boundary
        and collisions on the held joints, which a command may have made fail."""
        d = self.data
        if d.faults.error == 0:
            state, mode = d.motion_state, d.mode
            if mode == MODE_POSITION and state in _POSITION_STATES:
                plan = d.motion
                if plan.current is None and not plan.buffer:  # the executor is not active
                    if state == STATE_MOVING:
                        return False
                elif state == STATE_SLEEP or self.executor.dwell_rate(d.q) is None:  # a dwell counts time
                    return False
            elif mode == MODE_SERVO and d.servo_target is not None and state in _SERVO_STATES:
                if not (settled and state == STATE_SLEEP and self._servo_holding()):
                    return False
            elif (state == STATE_STOP and d.motion.stopping) or mode in MODE_STEPS:
                return False
        if not (self._known_still() or self._still()):
            return False
        for hook in EVERY_STEP:
            if not EVERY_STEP_IDLE.get(hook, _never_idle)(self):
                return False
        return True

    def _known_still(self) -> bool:
        """:meth:`_still` known without looking at the values: the state holds the very arrays the
        last period found +0 (nothing changes them in place but :meth:`raise_error`, which zeroes
        them; one that replaces them, a restore or an edit, is looked at again)."""
        known = self._still_rates
        return known is not None and known[0] is self.data.qd and known[1] is self.data.qdd

    def _still(self) -> bool:
        """The joint speeds and accelerations exactly +0: every byte zero (a -0.0 would show in a
        report)."""
        zeros = self._zeros
        return self.data.qd.tobytes() == zeros and self.data.qdd.tobytes() == zeros

    def ft_sensor_in_use(self) -> bool:
        """Whether an application reads the F/T sensor every period: admittance or force control
        (register 202) is set."""
        return force_control.engaged(self)

    def _servo_holding(self) -> bool:
        """Servo mode: the arm holds its target exactly, so a period gives the same joints again."""
        d = self.data
        tr = d.servo_tracker
        target = d.servo_target
        if tr is None or target is None:
            return False
        b = target.tobytes()
        return (tr.q.tobytes() == b and tr.target.tobytes() == b and d.q.tobytes() == b
                and not (tr.qd.any() or np.signbit(tr.qd).any() or tr.qdd.any() or np.signbit(tr.qdd).any()))

    def _tracker(self) -> motion.ServoTracker:
        d = self.data
        if d.servo_tracker is None:
            m = self.model
            d.servo_tracker = motion.ServoTracker(d.q, m.max_joint_speed, m.max_joint_acc)
        return d.servo_tracker

    def _check_safety(self, q_prev: np.ndarray) -> None:
        """Safety boundary (52, 59: C35) and self-collision (77, 78: C22) on the step just planned:
        the arm stops on the boundary or before contact (controller/core/safety.py)."""
        reduced.check_step(self, q_prev)  # reduced-mode joint ranges: C23
        s = self.settings
        if not (s.boundary_on or s.self_collision_on):
            return
        stop = safety.check_path_step(self.model, q_prev, self.q, self.collision_tool, s.self_collision_on,
                                      s.boundary, s.boundary_on, s.tcp_offset)
        if stop is not None:
            self.q = np.asarray(stop.q_stop, dtype=float)
            raise CommandError(stop.code, stop.reason)

    @property
    def counter(self) -> int:
        """Commands completed since power-on (rich report bytes 285-288)."""
        return self.executor.completed

    def limits(self) -> Limits:
        """The motion limits of the settings (registers 31-34) and the model (Table 1.2); the same
        object again while they stay (nothing changes a :class:`~.core.executor.Limits` once made)."""
        s = self.settings
        tcp_cap, joint_cap = reduced.speed_caps(self)
        key = (s.tcp_jerk, s.tcp_maxacc, s.joint_jerk, s.joint_maxacc, self.model.max_joint_speed,
               tcp_cap, joint_cap)
        cached = self._limits_cache
        if cached is not None and cached[0] == key:
            return cached[1]
        limits = Limits(*key)
        self._limits_cache = (key, limits)
        return limits

    def _step_position(self, dt: float) -> None:
        d = self.data
        plan = d.motion  # the executor's state: it is active while a command runs or waits
        if plan.current is None and not plan.buffer:
            fire(d, _IDLE)
            return
        d.q = self.executor.step(dt, d.q, self.limits(), self.flange_target, self.tcp_matrix)
        fire(d, _PLAN_RUNNING if plan.current is not None or plan.buffer else _PLAN_FINISHED)

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
        self.executor.discard()
        self.data.servo_target = None
        self.data.servo_tracker = None
        fire(self, Event.SYSTEM_RESET)
        self.enter_stop()

    def enter_stop(self) -> None:
        """Motion ended by a stop, an error or a system reset: components that have an ``on_stop()``
        method are told."""
        for c in self.components:
            on_stop = getattr(c, "on_stop", None)
            if on_stop is not None:
                on_stop()

    def require_motion_allowed(self, servo: bool = False) -> None:
        """Refuse motion commands that cannot run now (reply bit 0x10; nothing is queued)."""
        if self.error_code or not self.ready:
            raise NotReady()
        if servo and self.mode != MODE_SERVO:
            raise NotReady()
        if not servo and self.mode != MODE_POSITION:
            raise NotReady()

    def queue(self, cmd: QueuedCommand) -> dict[str, Any]:
        """Put a motion command into the buffer (warning 11 when full); the reply's buffer count."""
        if self.executor.cmdnum >= BUFFER_CAPACITY:
            raise CommandWarning(WARN_BUFFER_OVERFLOW)
        self.executor.queue(cmd)
        fire(self, Event.QUEUED)
        return {"cmdnum": self.executor.cmdnum}

    # torques (the dynamic model, model/dynamics.py)
    def joint_torques(self) -> np.ndarray:
        """:func:`joint_torques` of the box, computed again only when its inputs change (joints,
        speeds, accelerations, payload, gravity direction): an arm at rest is not recomputed for
        every report frame."""
        s, d = self.settings, self.data
        key = (d.q.tobytes(), d.qd.tobytes(), d.qdd.tobytes(), tuple(s.tcp_load), tuple(s.gravity_direction))
        if self._torque_cache is not None and self._torque_cache[0] == key:
            return self._torque_cache[1]
        tau = joint_torques(self.model, self.data, s)
        self._torque_cache = (key, tau)
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



def _ft_control_wrench(ctl: controller_protocol.Controller) -> np.ndarray | None:
    """What admittance and force control act on: the F/T sensor's control wrench, None while the
    sensor is switched off."""
    return ft_sensor.control_wrench(ctl) if ft_sensor.enabled(ctl) else None


def _never_idle(ctl: Controller) -> bool:
    return False


def _unread_axes_cleared(values: dict[str, Any], names: tuple[str, ...], dof: int) -> dict[str, Any]:
    """``values`` with the per-joint entries the box does not read for a ``dof``-axis arm set to 0:
    the joints beyond its axes, and the seventh of register 83's Cartesian deltas (x, y, z, roll,
    pitch, yaw). Whatever a client leaves there (stack garbage from the C++ SDK) is never refused."""
    used = dof
    if "deltas" in names and not values.get("is_joint_motion", 0):
        used = 6
    out = dict(values)
    for name in names:
        v = out.get(name)
        if isinstance(v, tuple) and len(v) > used and any(x != 0.0 for x in v[used:]):
            out[name] = v[:used] + (0.0,) * (len(v) - used)
    return out
