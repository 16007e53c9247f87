"""The in-process emulator: a :class:`Controller` with its peripherals, its
saved configuration and the report snapshot, driven by ``step()``.

This is the object the server runs and the object tests drive directly with a
stepped clock (``emu.advance(2.0)`` runs two seconds of controller time as fast
as the CPU allows, deterministically).
"""

from __future__ import annotations

import functools
import heapq
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..model import dynamics as dyn
from ..model import rotations as rot
from ..model.inertials import NOMINAL_JOINT_VOLTAGE
from ..model.robots import RobotModel, get_model
from ..protocol.firmware import DEFAULT_PROFILE, FirmwareProfile, profile_for
from ..protocol.reports import ReportSnapshot
from ..protocol.rtu import CONTROL_BOX_HOST
from . import physics
from .applications import identification, trajectory
from .box_state import EmulatorState, ModbusUserState, Schedule
from .controller import Controller, joint_torques, tcp_matrix
from .core import safety, state_bytes
from .core.config import ConfigStore
from .core.controller_state import ControllerState
from .core.device import Device
from .core.faults import Faults
from .core.feedback import FeedbackQueue, feedback_queue, find_feedback_queue
from .core.interface import C_COLLISION, C_END_MODULE, C_ESTOP, C_SERVO_BASE, PERIOD, idle_until
from .core.jump import SCHEDULE_SLACK, tick
from .core.jump import jump as jump_over
from .core.settings import Settings
from .core.thermal import THERMAL_EVERY, ThermalModel
from .devices import ft_sensor
from .devices.bio_gripper import BioGripper
from .devices.bio_gripper_g1 import BioGripperG1
from .devices.ft_sensor import state_of as sensor_state_of
from .devices.gripper import GripperModule, ToolDevice
from .devices.inspire_hand import InspireHand
from .devices.io import IOModule
from .devices.linear_track import TRACK_BAUD_INDEX, TRACK_ID, LinearTrack
from .devices.lite6_gripper import Lite6Gripper
from .devices.robotiq import MODELS as ROBOTIQ_MODELS
from .devices.robotiq import RobotiqGripper
from .devices.vacuum import VacuumGripper
from .firmware2_report import firmware2_fields
from .scene import contact

log = logging.getLogger("xarm_emu.emulator")

#: The devices that can be attached on the tool RS-485 (``Emulator(gripper=...)``, ``serve --gripper``),
#: each with what makes one: the xArm gripper (controller/devices/gripper.py, which the gripper module
#: always has), the Robotiq 2F-85 and 2F-140 (robotiq.py), the BIO gripper G2 (bio_gripper.py) and G1
#: (bio_gripper_g1.py) and the Inspire RH56 hand (inspire_hand.py).
TOOL_DEVICES: Mapping[str, Callable[[], ToolDevice] | None] = {
    "xarm": None,
    **{name: functools.partial(RobotiqGripper, model) for name, model in ROBOTIQ_MODELS.items()},
    "bio": BioGripper,
    "bio-g1": BioGripperG1,
    "inspire-rh56": InspireHand,
}
#: Their names, in that order.
GRIPPERS = tuple(TOOL_DEVICES)


def tool_device(gripper: str) -> ToolDevice | None:
    """The tool-bus device of ``gripper`` (one of :data:`GRIPPERS`); None for the xArm gripper,
    which the gripper module always has. Raises ValueError for an unknown name."""
    if gripper not in TOOL_DEVICES:
        raise ValueError(f"gripper {gripper!r}: one of {', '.join(GRIPPERS)}")
    make = TOOL_DEVICES[gripper]
    return None if make is None else make()


def _bits(flags: list[bool]) -> int:
    out = 0
    for i, f in enumerate(flags):
        if f:
            out |= 1 << i
    return out


def box_parts(model: RobotModel, *, gripper: str = "xarm", vacuum: bool = False,
              linear_track: int | None = None, ft_sensor: bool = False) -> tuple[str, ...]:
    """The parts a box is built with, by the names of protocol/firmware.py's ``PARTS``: the arm, the
    tool-bus gripper, the vacuum gripper, the linear track, the F/T sensor."""
    return (f"{model.name} arm", f"{gripper} gripper") + ("vacuum gripper",) * vacuum + (
        ("linear track",) * (linear_track is not None) + ("F/T sensor",) * ft_sensor)


def check_firmware(model: RobotModel, firmware: FirmwareProfile, *, gripper: str = "xarm",
                   vacuum: bool = False, linear_track: int | None = None, ft_sensor: bool = False) -> None:
    """Refuse a box whose firmware cannot drive one of its parts (the one rule of
    ``FirmwareProfile.check_parts``; the parts and the release each needs are protocol/firmware.py's
    ``PARTS`` and ``RELEASES``): a ``FirmwareRefusal`` (a ValueError) with one line."""
    firmware.check_parts(*box_parts(model, gripper=gripper, vacuum=vacuum, linear_track=linear_track,
                                    ft_sensor=ft_sensor))


@dataclass(frozen=True)
class Checkpoint:
    """The whole state of an emulator at one instant (:meth:`Emulator.checkpoint`): its
    :class:`~.box_state.EmulatorState` tree written as a whole (controller and motion with the
    buffer, plan and ramps, settings, IO, every attached device, the Modbus user storage, the
    tool bus timeouts, the thermal model, the pending scheduled actions and the clock), as the
    bytes of :meth:`Emulator.checkpoint_bytes`. Bytes do not change: restoring it any number of
    times gives the same state."""

    #: The state tree as bytes (:mod:`.core.state_bytes`).
    data: bytes
    #: Controller time at the checkpoint, s.
    time: float
    #: The fixed objects the bytes refer to by name (the emulator's, :meth:`Emulator._fixed`).
    fixed: Mapping[str, object] = field(repr=False, compare=False)

    @property
    def state(self) -> EmulatorState:
        """The saved tree read back: a new copy on each call, sharing nothing mutable with the box."""
        state, _ = state_bytes.decode(self.data, self.fixed)
        return cast(EmulatorState, state)


def report_snapshot(model: RobotModel, data: ControllerState, settings: Settings, io: IOModule,
                    thermal: ThermalModel, *, version: str, tool_error: int = 0,
                    torques: np.ndarray | None = None, pose: np.ndarray | None = None) -> ReportSnapshot:
    """What the reports show (manual section 2.1.6) of a box: its model, state and settings, its IO
    and thermal model, register 1's version string and the end tool's error code; reads only.
    ``torques`` and ``pose`` may be given where they are already known (the controller's caches)."""
    s, m, dof = settings, model, model.dof
    pad = (0.0,) * (7 - dof)
    tau = joint_torques(m, data, s) if torques is None else torques
    currents = dyn.torques_to_currents(m, tau)
    reported = currents if s.report_current else tau
    T = tcp_matrix(m, data.q, s) if pose is None else pose
    faults = data.faults
    return ReportSnapshot(
        state=data.motion_state,
        mode=data.mode,
        cmdnum=data.motion.cmdnum,
        joints=tuple(float(x) for x in data.q) + pad,
        pose=tuple(float(x) for x in rot.matrix_to_pose(T)),
        torques=tuple(float(x) for x in reported) + pad,
        brake_bits=_bits(data.brakes),
        enable_bits=_bits(data.enabled),
        error=faults.error,
        warning=faults.warning,
        tcp_offset=tuple(s.tcp_offset),
        tcp_load=tuple(s.tcp_load),
        collision_sensitivity=s.collision_sensitivity,
        teach_sensitivity=s.teach_sensitivity,
        gravity_direction=tuple(s.gravity_direction),
        robot_type=m.robot_type,
        axis=m.axis,
        version=version,
        tcp_jerk=s.tcp_jerk,
        tcp_max_acc=s.tcp_maxacc,
        tcp_max_speed=m.max_tcp_speed,
        joint_jerk=s.joint_jerk,
        joint_max_acc=s.joint_maxacc,
        joint_max_speed=m.max_joint_speed,
        servo_codes=tuple((1 if e else 0, e) for e in faults.servo_errors) + ((0, 0),) * (7 - dof),
        tcp_speed=float(data.motion.tcp_speed),
        joint_speeds=tuple(float(x) for x in data.qd) + pad,
        counter=data.motion.completed,
        world_offset=tuple(s.world_offset),
        simulation=data.simulation_robot,
        self_collision=s.self_collision_on,
        collision_tool_type=int(s.collision_tool[0]),
        collision_tool_params=tuple(s.collision_tool[1:7]),
        joint_currents=tuple(float(x) for x in currents) + pad,
        joint_voltages=(NOMINAL_JOINT_VOLTAGE,) * dof + pad,
        temperatures=tuple(thermal.celsius_u8()) + (0,) * (7 - dof),
        tgpio_code=(1 if tool_error else 0, tool_error),
        **io.snapshot_fields(),
    )


class Emulator:
    """One emulated xArm control box (controller, peripherals, configuration)."""

    def __init__(self, model: int | str | RobotModel = 6, *, robot_sn: str | None = None,
                 box_sn: str | None = None, config_dir: Path | None = None, load_config: bool = True,
                 vacuum: bool = False, firmware: str | FirmwareProfile = DEFAULT_PROFILE,
                 linear_track: int | None = None, exact_steps: bool = False,
                 ft_sensor: bool = False, ft_noise: bool = True,
                 scene: contact.Scene | None = None, gripper: str = "xarm") -> None:
        self.model = model if isinstance(model, RobotModel) else get_model(model)
        device = tool_device(gripper)
        if vacuum and device is not None:
            raise ValueError(f"one end tool at a time: the vacuum gripper or the {gripper} gripper")
        #: Which gripper is on the tool RS-485 (:data:`GRIPPERS`).
        self.gripper_kind = gripper
        sn = robot_sn or self.model.default_robot_sn
        box_sn = box_sn or self.model.default_box_sn
        #: The firmware version this box claims (register 1) and whose behaviour it has.
        self.firmware = firmware if isinstance(firmware, FirmwareProfile) else profile_for(firmware)
        check_firmware(self.model, self.firmware, gripper=gripper, vacuum=vacuum, linear_track=linear_track,
                       ft_sensor=ft_sensor)
        self.controller = Controller(self.model, robot_sn=sn, box_sn=box_sn, period=PERIOD,
                                     firmware=self.firmware)
        #: Every device plugged in (controller/core/device.py), in the order they step.
        self.devices: list[Device] = []
        self._plug_io_and_tools(box_sn, device, vacuum)
        self._plug_linear_track(linear_track)
        #: The feedback queue of firmware 2.x (registers 253/254, 0xFF frames), part of the box
        #: from the start so that every checkpoint holds it.
        self.feedback: FeedbackQueue | None = (feedback_queue(self.controller) if self.firmware.feedback
                                               else None)
        #: Counts the changes that do not come from the control periods themselves: every command,
        #: restore and change from outside the protocol (:meth:`touch`). With :meth:`next_event` it
        #: tells whether anything can have changed since a moment (:meth:`mark`, :meth:`unchanged`).
        self.generation = 0
        sensor_state_of(self.controller)  # mounted or not, its state is part of the box from the start
        if ft_sensor:  # the six-axis F/T sensor between flange and tool (controller/devices/ft_sensor.py)
            self.attach_ft_sensor(noise=ft_noise)
        if scene is not None:
            contact.set_scene(self.controller, scene)
        self._attach_physics(scene)
        self.thermal = ThermalModel.for_model(self.model)
        self._start_clock(exact_steps)
        #: Actions due at a controller time (:meth:`at`); ``_scheduled`` is its heap.
        self.schedule = Schedule()
        self._scheduled = self.schedule.heap
        #: Objects of the layers above that scheduled actions refer to (the server a fault schedule
        #: acts on), by name: a checkpoint writes the name and a restore finds the object again.
        self.outside: dict[str, object] = {}
        #: What Modbus-TCP clients store in the box (controller/modbus_map.py).
        self.modbus = ModbusUserState()
        self.config_dir = config_dir
        trajectory.attach(self.controller, config_dir)  # trajectory files (registers 62/63)
        self.config_message: str | None = None
        #: The saved configuration this box started with (the values of its file), else ``None``.
        self.loaded_config: dict[str, Any] | None = None
        self._store: Any = None
        if config_dir is not None:
            self._attach_store(Path(config_dir), load_config)

    def _attach_physics(self, scene: contact.Scene | None) -> None:
        #: The physics world of a scene with objects or cell elements (controller/physics/), else None.
        self.physics = physics.attach(self.model, scene, self.gripper_kind, self.gripper.device, self.vacuum,
                                      io=self.io, lite6=self.lite6_gripper) if (
            scene is not None and scene.physical) else None
        if self.physics is not None:
            self.controller.add_component(self.physics)

    def _start_clock(self, exact_steps: bool) -> None:
        """What :meth:`step` keeps between calls."""
        #: Run every control period one by one, never jumping over idle ones (:meth:`step`); the
        #: results are the same either way, this switch is there to show it.
        self.exact_steps = exact_steps
        #: Control periods jumped over so far (not stepped one by one; :mod:`.core.jump`).
        self.periods_jumped = 0
        self._rest_cache: tuple[tuple[Any, ...], np.ndarray] | None = None
        self._settled = -1  # the generation at the end of the last step() call
        #: (generation, period) of the last :meth:`next_event` answer, kept while it holds.
        self._next_event: tuple[int, float] = (-1, -math.inf)

    def _plug_io_and_tools(self, box_sn: str, device: ToolDevice | None, vacuum: bool) -> None:
        """The IO, the tool RS-485 bus with ``device`` on it, and the end tools on the tool IO (the
        vacuum gripper when ``vacuum``, the Lite 6 gripper on the arms wired for it)."""
        box_number = int(box_sn[2:6]) if box_sn[2:6].isdigit() else 0
        # Control boxes with SN >= 1300 have 16 digital IO, as the SDK expects.
        self.io = IOModule(n_digital=16 if box_number >= 1300 else 8,
                           tool_ti2=self.model.tool_io.ti2_address is not None)
        self.gripper = GripperModule(tool_baud=lambda: self.io.tool.baud_index[9], device=device)
        self._plug(self.io)
        self.io.attach(self.controller)
        self._plug(self.gripper)
        self.controller.hooks.tool_error = self._tool_error
        #: The vacuum gripper's pressure switch on TI0 (controller/devices/vacuum.py), when attached.
        self.vacuum: VacuumGripper | None = None
        if vacuum:
            self.vacuum = VacuumGripper(self.io.tool)
            self._plug(self.vacuum)
        #: The Lite 6 gripper's jaws on TO0/TO1 (controller/devices/lite6_gripper.py), on the arms
        #: wired for it.
        self.lite6_gripper: Lite6Gripper | None = None
        if self.model.tool_io.gripper is not None:
            self.lite6_gripper = Lite6Gripper(self.io.tool, self.model.tool_io.gripper)
            self._plug(self.lite6_gripper)

    def _plug(self, device: Device) -> None:
        """Plug ``device`` in: it steps with the controller and answers its registers' bindings."""
        self.controller.add_component(device)
        self.devices.append(device)

    def _plug_linear_track(self, linear_track: int | None) -> None:
        """The linear track of ``linear_track`` mm on the control box RS-485, when given."""
        #: The linear track on the control box RS-485 (controller/devices/linear_track.py), ``linear_track``
        #: mm long, when attached.
        self.linear_track: LinearTrack | None = None
        if linear_track is not None:
            self.linear_track = track = LinearTrack(linear_track)
            self._plug(track)
            self.gripper.box_devices = lambda: (
                {TRACK_ID: track} if self.io.tool.baud_index[CONTROL_BOX_HOST] == TRACK_BAUD_INDEX else {})

    def _tool_error(self) -> int:
        """The end tool's error code (register 106): what the box reports of the device on the tool
        bus (``ToolDevice.reported_error``)."""
        return self.gripper.device.reported_error

    # -- configuration (register 39/40) -------------------------------------------------------
    def _attach_store(self, directory: Path, load: bool) -> None:
        self._store = ConfigStore(directory, self.controller.robot_sn)
        ctl = self.controller
        ctl.hooks.on_save = self._save_config
        ctl.hooks.on_clean_conf = self._clean_config
        if load:
            data = self._store.load()
            if data is not None:
                self.loaded_config = data
                ctl.load_config(data)
                io = data.get("io")
                if isinstance(io, dict):
                    self.io.load_config(io)
            msg = getattr(self._store, "last_error", None)
            if msg:
                self.config_message = str(msg)
                log.warning("%s", msg)

    def _save_config(self, values: dict[str, Any]) -> None:
        values = dict(values)
        values["io"] = self.io.config()
        self._store.save(values)

    def _clean_config(self) -> None:
        """Register 39: delete the saved configuration and restore the defaults."""
        self._store.delete()
        self.io.load_config(IOModule().config())

    # -- protocol ------------------------------------------------------------------------------
    def handle(self, code: int, params: bytes) -> tuple[int, bytes]:
        self.generation += 1
        return self.controller.handle(code, params)

    def touch(self) -> None:
        """Mark the state as changed from outside a command or a step (injection, test code)."""
        self.generation += 1

    def step(self, n: int = 1) -> None:
        """Run ``n`` control periods.

        Unless :attr:`exact_steps` is set: a call whose periods all come before :meth:`next_event`
        runs only the clock (:func:`.core.jump.tick`); otherwise periods in which nothing would
        change but the clock are jumped over (:func:`.core.jump.jump`), and the last period of the
        call and the period in which anything falls due run in full. Everything anyone can observe,
        and the whole state tree, comes out as if every period had run
        (``tests/test_clock_exact.py``, ``tests/test_state_bytes.py``)."""
        ctl = self.controller
        fast = not self.exact_steps
        if n > 0 and fast and ctl.data.steps + n < self.next_event():
            # Every period of the call comes before the next event: none would change anything but
            # the clock (:meth:`next_event`), so only the clock runs, the last period too. This is
            # what a report frame or a command costs an arm at rest.
            tick(ctl.data, ctl.period, n)
            self.periods_jumped += n
            self._settled = self.generation
            return
        if n <= 0:
            return
        settled = self.generation == self._settled  # nothing changed the box since the last call
        step, at_rest, scheduled = ctl.step, ctl.at_rest, self._scheduled
        i = 0
        while i < n:
            if fast and i < n - 1 and at_rest(settled):
                due = scheduled[0][0] if scheduled else math.inf
                k = jump_over(ctl, self.thermal, due, n - 1 - i, self._rest_currents)
                if k:
                    self.periods_jumped += k
                    i += k
                    continue
            # one period in full, with the thermal step and the scheduled actions due in it
            step()
            settled = True  # nothing but the period changed the box
            d = ctl.data
            if d.steps % THERMAL_EVERY == 0:
                self.thermal.step(THERMAL_EVERY * ctl.period, np.abs(ctl.joint_currents()))
            if scheduled and scheduled[0][0] <= d.time + SCHEDULE_SLACK:
                self._run_scheduled()
                settled = False
            i += 1
        self._settled = self.generation

    # -- when the box next changes on its own --------------------------------------------------
    def next_event(self) -> float:
        """The first control period (numbered as ``controller.steps`` counts them) whose step may
        change anything but the clock, unless something outside changes the box first
        (:attr:`generation`): the next period while the arm moves, a dwell or a stop runs, a command
        has just changed the box or the F/T sensor's readings follow the clock; else the period of
        the next thermal step, component event (:func:`~.core.interface.idle_until`: a gripper or
        the track moving, a delayed output, a timeout) or scheduled action, whichever comes first
        (``math.inf``: none). A lower bound: every period before it, stepped in any calls, leaves
        every register and every report without the clock as it was.

        The one rule behind everything that is kept while the box is quiet (report frames without
        the clock, pure reads' replies): keep it with :meth:`mark` and use it while
        :meth:`unchanged` says so.

        Kept while it holds (nothing outside changed the box and its period has not come): the
        box is the same then but for the clock, so the answer is too."""
        generation, event = self._next_event
        if generation == self.generation and self.controller.data.steps < event:
            return event
        event = self._find_next_event()
        self._next_event = (self.generation, event)
        return event

    def _find_next_event(self) -> float:
        ctl = self.controller
        d = ctl.data
        if not self._quiet_now(self.generation == self._settled):
            return d.steps + 1
        dt = ctl.period
        count: float = THERMAL_EVERY - 1 - d.steps % THERMAL_EVERY  # the thermal step's period is not
        due = min((idle_until(c, ctl) for c in ctl.components), default=math.inf)
        if self._scheduled:
            due = min(due, self._scheduled[0][0] - SCHEDULE_SLACK)
        span = (due - d.time) / dt  # periods to the next event (inf: none; -inf: a busy component)
        if span < count + 2:
            count = math.floor(span) - 1 if span > 1.0 else 0
        return d.steps + 1 + max(0, count)

    def mark(self) -> tuple[int, float]:
        """The moment now, for :meth:`unchanged`: (:attr:`generation`, :meth:`next_event`)."""
        return self.generation, self.next_event()

    def unchanged(self, mark: tuple[int, float]) -> bool:
        """Whether everything a register or a report without the clock shows is still what it was at
        ``mark`` (:meth:`mark`): nothing outside has changed the box and no period at or after the
        mark's :meth:`next_event` has run."""
        return mark[0] == self.generation and self.controller.data.steps < mark[1]

    def _quiet_now(self, settled: bool) -> bool:
        """The controller at rest (:meth:`Controller.at_rest`) with no command in its buffer (a
        dwell counts time at rest, yet its last period ends it: cmdnum and state change) and no
        F/T sensor (its readings follow the clock: noise, drift, wrench ramps)."""
        ctl = self.controller
        return ctl.at_rest(settled) and not ctl.executor.active and not ft_sensor.attached(ctl)

    def _rest_currents(self) -> np.ndarray:
        """``abs(joint_currents())`` of the arm at rest, kept while the joints and the load stay (what
        the torques depend on besides the speeds and accelerations, zero at rest)."""
        ctl = self.controller
        s = ctl.settings
        key = (ctl.data.q.tobytes(), tuple(s.tcp_load), tuple(s.gravity_direction))
        if self._rest_cache is None or self._rest_cache[0] != key:
            self._rest_cache = (key, np.abs(ctl.joint_currents()))
        return self._rest_cache[1]

    def at(self, seconds: float, action: Callable[[], object]) -> None:
        """Run ``action`` right after the first control period that ends at or after controller time
        ``seconds`` (a fault schedule, server/faults.py). Actions due at the same time run in the order
        given; one that raises is logged and the others still run."""
        if not math.isfinite(seconds):
            raise ValueError(f"time must be finite, got {seconds!r}")
        self.schedule.seq += 1
        heapq.heappush(self._scheduled, (float(seconds), self.schedule.seq, action))

    def _run_scheduled(self) -> None:
        now = self.controller.time + SCHEDULE_SLACK
        while self._scheduled and self._scheduled[0][0] <= now:
            _, _, action = heapq.heappop(self._scheduled)
            try:
                action()
            except Exception:  # noqa: BLE001 - a scheduled action must not stop the control loop
                log.exception("scheduled action at t = %.3f s failed", self.controller.time)

    def advance(self, seconds: float) -> None:
        """Run ``seconds`` of controller time now (stepped clock)."""
        self.step(max(0, round(seconds / self.controller.period)))

    @property
    def time(self) -> float:
        return self.controller.time

    # -- reports -------------------------------------------------------------------------------
    def snapshot(self) -> ReportSnapshot:
        """The live state as the reports show it (manual section 2.1.6)."""
        c = self.controller
        snap = report_snapshot(c.model, c.data, c.settings, self.io, self.thermal,
                               version=c.version_string(), tool_error=c.hooks.tool_error(),
                               torques=c.joint_torques(), pose=c.tcp_matrix())
        snap.iden_progress = identification.progress(c)  # rich report byte 481
        if ft_sensor.enabled(c):  # the reports' F/T fields: what registers 200 and 200 [01] answer
            snap.ft_ext_force = tuple(float(x) for x in ft_sensor.reading(c))
            snap.ft_raw_force = tuple(float(x) for x in ft_sensor.raw_reading(c))
            snap.ft_enabled = True
        if self.firmware.reports_2x:  # what the 2.x frames carry beyond the manual's
            firmware2_fields(c, snap)
        return snap

    # -- checkpoint and restore (no real control box has these) ---------------------------------
    @property
    def state(self) -> EmulatorState:
        """Every mutable value of the box as one tree (:class:`~.box_state.EmulatorState`): the
        live objects themselves, each part the one its component works on now."""
        ctl, g = self.controller, self.gripper
        return EmulatorState(
            controller=ctl.data, settings=ctl.settings, io=self.io.data, tool_bus=g.data,
            xarm_gripper=g.gripper.data, thermal=self.thermal.data, modbus=self.modbus,
            schedule=self.schedule,
            tool_device=None if g.device is g.gripper else g.device.data,
            vacuum=None if self.vacuum is None else self.vacuum.data,
            lite6_gripper=None if self.lite6_gripper is None else self.lite6_gripper.data,
            linear_track=None if self.linear_track is None else self.linear_track.data,
            feedback=None if (fq := find_feedback_queue(ctl)) is None else fq.data,
            physics=None if self.physics is None else self.physics.world.capture())

    def _adopt(self, state: EmulatorState) -> None:
        """Make ``state`` the box's state, each part handed to its component as a whole."""
        ctl, g = self.controller, self.gripper
        ctl.adopt(state.controller, state.settings)
        self.io.data = state.io
        g.data, g.gripper.data = state.tool_bus, state.xarm_gripper
        self.thermal.data = state.thermal
        self.modbus = state.modbus
        self.schedule = state.schedule
        self._scheduled = state.schedule.heap
        if state.tool_device is not None:
            g.device.data = state.tool_device
        if self.vacuum is not None and state.vacuum is not None:
            self.vacuum.data = state.vacuum
            self.vacuum.tool = self.io.tool
        if self.lite6_gripper is not None and state.lite6_gripper is not None:
            self.lite6_gripper.data = state.lite6_gripper
            self.lite6_gripper.tool = self.io.tool
        if self.linear_track is not None and state.linear_track is not None:
            self.linear_track.data = state.linear_track
        if (fq := find_feedback_queue(ctl)) is not None and state.feedback is not None:
            fq.data = state.feedback
        if self.physics is not None and state.physics is not None:
            self.physics.restore(state.physics)

    def checkpoint(self) -> Checkpoint:
        """The whole emulator state, written as bytes (:class:`Checkpoint`, :meth:`checkpoint_bytes`).
        Raises :class:`~.core.state_bytes.StateBytesError` when a scheduled action has no written
        form (a lambda: schedule a ``functools.partial`` of a module-level function instead)."""
        return Checkpoint(self.checkpoint_bytes(), self.time, self._fixed())

    def restore(self, cp: Checkpoint) -> None:
        """Put the state of ``cp`` back exactly, as a whole; ``cp`` stays usable for further restores.
        A checkpoint of another kind of box is refused (a ValueError) and changes nothing."""
        self.restore_bytes(cp.data)

    def _fixed(self) -> dict[str, object]:
        """The fixed objects a state tree refers to (tasks in the command buffer call their methods,
        scheduled actions act on the server of :attr:`outside`), by the names its bytes give them."""
        return {**self.outside, "model": self.model, "controller": self.controller, "emulator": self,
                "io": self.io, "gripper": self.gripper}

    def _identity(self) -> dict[str, str]:
        """What box a saved state belongs to: the arm, the firmware and the tool-bus gripper."""
        return {"model": self.model.name, "firmware": str(self.firmware), "gripper": self.gripper_kind}

    def checkpoint_bytes(self) -> bytes:
        """The whole emulator state as bytes (:mod:`.core.state_bytes`), for a file or another process:
        :meth:`restore_bytes` of an emulator built with the same options puts it back, the running
        motion included (planned again from its inputs). Raises
        :class:`~.core.state_bytes.StateBytesError` when the state holds a value that has no written
        form (a lambda among the scheduled actions)."""
        return state_bytes.encode(self.state, self._fixed(), self._identity())

    def restore_bytes(self, data: bytes) -> None:
        """Put back a state saved by :meth:`checkpoint_bytes`, as a whole. Raises
        :class:`~.core.state_bytes.StateBytesError` (a ValueError) for bytes that are no saved state
        or belong to another kind of box; the box is unchanged then."""
        state, meta = state_bytes.decode(data, self._fixed())
        if meta != self._identity():
            mine = self._identity()
            diff = ", ".join(f"{k} {meta.get(k)!r} (this box: {v!r})" for k, v in mine.items()
                             if meta.get(k) != v)
            raise state_bytes.StateBytesError(f"a saved state of another box: {diff}")
        sensor = state.controller.ft_sensor if isinstance(state, EmulatorState) else None
        if (not isinstance(state, EmulatorState) or state.layout() != self.state.layout()
                or bool(getattr(sensor, "attached", False)) != self.has_ft_sensor):
            raise state_bytes.StateBytesError("a saved state of an emulator with other components "
                                              "(grippers, linear track, F/T sensor)")
        self.generation += 1
        self._adopt(state)

    # -- in-process API ------------------------------------------------------------------------
    @property
    def joints(self) -> np.ndarray:
        return self.controller.q.copy()

    def gripper_status(self) -> dict[str, Any]:
        """The device on the tool bus as the status output and the view show it: its kind, its error
        code and what it shows of itself (``status_fields``: opening or position, enabled or
        activated, an object held)."""
        dev = self.gripper.device
        return {"gripper": self.gripper_kind, "error": dev.error, **dev.status_fields()}

    # -- fault injection and inputs from outside (the admin channel calls these) -------------
    def inject_error(self, code: int) -> None:
        """Raise control box error C<code> exactly as the natural cause would (section 3.2.1)."""
        self.generation += 1
        if not 1 <= code <= 255:
            raise ValueError(f"error code {code} out of range 1..255")
        self.controller.raise_error(code)

    def inject_estop(self) -> None:
        """The emergency stop button: error C1, joints disabled until re-enabled."""
        self.generation += 1
        self.controller.raise_error(C_ESTOP)

    def inject_warning(self, code: int) -> None:
        """Set warning ``code`` (section 3.2.2); nothing else changes."""
        self.generation += 1
        if not 1 <= code <= 255:
            raise ValueError(f"warning code {code} out of range 1..255")
        self.controller.raise_warning(code)

    def inject_servo_error(self, joint: int, code: int) -> None:
        """A joint (servo) error S<code> on ``joint`` (1-based, section 3.1): error C10+joint."""
        self.generation += 1
        ctl = self.controller
        if not 1 <= joint <= ctl.dof:
            raise ValueError(f"joint {joint} out of range 1..{ctl.dof}")
        if not 1 <= code <= 255:
            raise ValueError(f"servo error code {code} out of range 1..255")
        ctl.servo_errors[joint - 1] = code
        ctl.raise_error(C_SERVO_BASE + joint)

    def inject_gripper_error(self, code: int) -> None:
        """A gripper error of the attached gripper (section 3.3 for the xArm gripper; the Robotiq's
        gFLT faults, the BIO grippers' codes: protocol/codes.py ``GRIPPER_TABLES``; the Inspire hand's
        error byte), read through the gripper's own registers."""
        self.generation += 1
        self.gripper.device.inject_error(code)

    def inject_track_error(self, code: int) -> None:
        """A linear track drive error (the SDK's linear motor codes, read at 0x0A23 over register 124)."""
        self.generation += 1
        if self.linear_track is None:
            raise ValueError("no linear track is attached (Emulator(linear_track=700), serve --linear-track)")
        self.linear_track.inject_error(code)

    def inject_end_module_lost(self) -> None:
        """The end module stops answering: error C28 (end module communication)."""
        self.generation += 1
        self.controller.raise_error(C_END_MODULE)

    def inject_collision(self, joint: int, torque: float) -> bool:
        """An external ``torque`` (N m) on ``joint`` (1-based), as a collision would apply.

        Detected (error C31, manual 3.2.1) when the joints are enabled and the torque reaches the
        threshold of the collision sensitivity (register 37; ``safety.collision_thresholds``);
        sensitivity 0 switches detection off. Returns whether it was detected.
        """
        self.generation += 1
        ctl = self.controller
        if not 1 <= joint <= ctl.dof:
            raise ValueError(f"joint {joint} out of range 1..{ctl.dof}")
        if not math.isfinite(torque):
            raise ValueError(f"torque must be finite, got {torque!r}")
        if ctl.error_code or not all(ctl.enabled):
            return False
        if not safety.collision_detected(ctl.settings.collision_sensitivity, torque,
                                         safety.collision_thresholds(ctl.model)):
            return False
        ctl.raise_error(C_COLLISION)
        return True

    def clear_faults(self) -> None:
        """Clear every injected fault at once (errors, warnings, servo, gripper and track errors)."""
        self.generation += 1
        ctl = self.controller
        ctl.faults = Faults.none(ctl.dof)
        for device in self.devices:
            device.clear_error()

    # -- the F/T sensor and the contact scene (devices/ft_sensor.py, scene/contact.py) ----
    def attach_ft_sensor(self, *, noise: bool = True) -> None:
        """Mount the six-axis F/T sensor between flange and tool (once); a firmware that cannot drive
        it is refused (``FirmwareRefusal``, as at construction)."""
        self.firmware.check_parts("F/T sensor")
        self.generation += 1
        if not ft_sensor.attached(self.controller):
            ft_sensor.attach(self.controller, noise=noise)
            self._plug(ft_sensor.FtSensorComponent(self.controller))

    @property
    def has_ft_sensor(self) -> bool:
        return ft_sensor.attached(self.controller)

    def apply_wrench(self, wrench: Any, frame: str = "tool", ramp_s: float = 0.0,
                     duration_s: float | None = None) -> None:
        """An external wrench on the TCP (:func:`.devices.ft_sensor.apply_wrench`); ValueError if not
        finite."""
        self.generation += 1
        ft_sensor.apply_wrench(self.controller, wrench, frame, ramp_s, duration_s)

    def clear_wrench(self) -> None:
        """Remove every played external wrench."""
        self.generation += 1
        ft_sensor.clear_wrench(self.controller)

    def set_ft_noise(self, on: bool) -> None:
        """Switch the F/T sensor's noise and drift on or off."""
        self.generation += 1
        ft_sensor.set_noise(self.controller, on)

    def set_payload(self, mass: float, com: Any) -> None:
        """Declare the physical payload on the tool (kg, centre of mass mm in the flange frame)."""
        self.generation += 1
        ft_sensor.set_payload(self.controller, mass, com)

    def set_scene(self, scene: contact.Scene) -> None:
        """Make ``scene`` the contact scene (planes and boxes in the base frame), and the physics
        world's: rebuilt for its objects and cell elements, those already there going on where they
        are, the arm untouched (ValueError for a scene the world cannot take)."""
        self.generation += 1
        if self.physics is not None:
            self.physics.rebuild(scene, self.controller.q)
        elif scene.physical:
            self.physics = physics.attach(self.model, scene, self.gripper_kind, self.gripper.device,
                                          self.vacuum, io=self.io, lite6=self.lite6_gripper)
            self.controller.add_component(self.physics)
        contact.set_scene(self.controller, scene)

    # -- objects of the physics world (controller/physics/) -------------------------------------
    def scene_objects(self) -> list[dict[str, Any]]:
        """Every object's pose (mm, base frame; roll/pitch/yaw deg) and whether the hand holds it;
        empty without objects."""
        return [] if self.physics is None else [vars(p) for p in self.physics.world.poses()]

    def place_object(self, name: str, position: Any, rpy: Any = (0.0, 0.0, 0.0)) -> None:
        """Put object ``name`` at ``position`` (mm) turned by ``rpy`` (deg), at rest; ValueError if
        there is no such object."""
        self.generation += 1
        if self.physics is None:
            raise ValueError("the scene has no objects (serve --scene with [[object]] tables)")
        self.physics.world.place(name, tuple(position), tuple(rpy))

    def reset_objects(self) -> None:
        """Every object back where the scene file puts it, at rest."""
        self.generation += 1
        if self.physics is None:
            raise ValueError("the scene has no objects (serve --scene with [[object]] tables)")
        self.physics.world.reset(self.controller.q)

    def inject_ft_error(self, code: int) -> None:
        """The F/T sensor reports error ``code`` (as get_ft_sensor_error reads it)."""
        self.generation += 1
        ft_sensor.inject_error(self.controller, code)

    def set_input(self, kind: str, index: int, value: float) -> None:
        """Play a sensor: ``cgpio``/``tgpio`` digital inputs (0/1), ``analog`` (control box, V),
        ``tool-analog`` (V), ``vacuum-object`` 0 (1: an object seals the vacuum cup, 0: none), or
        ``gripper-object`` (an object of ``value`` mm between the Robotiq's or BIO gripper's fingers,
        index 0, or around the Robotiq's, index 1, gripped by opening; 0 takes it away)."""
        self.generation += 1
        self.check_input(kind, index, value)
        if kind == "gripper-object":
            self.gripper.device.set_object(float(value) if value > 0 else None, inner=index == 1)
            return
        if kind == "vacuum-object":
            assert self.vacuum is not None
            self.vacuum.object_present = bool(value)
            return
        self.io.set_input(kind, index, value)

    def check_input(self, kind: str, index: int, value: float | None = None) -> None:
        """Raise ValueError (or ParameterError) unless :meth:`set_input` can play ``kind`` ``index``
        (and, where given, ``value``)."""
        if kind == "gripper-object":
            places = self.gripper.device.object_places
            if not places:
                raise ValueError("gripper-object needs a Robotiq or BIO gripper (serve --gripper "
                                 "robotiq-2f85, robotiq-2f140, bio or bio-g1)")
            if index not in places:
                around = " or 1 (around them)" if 1 in places else ""
                raise ValueError(f"index 0 (an object between the fingers){around}, not {index}")
            if value is not None and not math.isfinite(value):
                raise ValueError(f"object width must be finite, got {value!r}")
            if value is not None and value > 0:
                self.gripper.device.check_object(value, inner=index == 1)
            return
        if kind == "vacuum-object":
            if self.vacuum is None:
                raise ValueError("no vacuum gripper is attached (Emulator(vacuum=True), serve --vacuum)")
            if index != 0:
                raise ValueError(f"the vacuum gripper has one cup: index 0, not {index}")
            return
        self.io.check_input(kind, index)
