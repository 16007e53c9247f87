"""The whole mutable state of one emulated control box as one tree of dataclasses.

:class:`EmulatorState` has one field per part of the box: the controller's
:class:`~.core.controller_state.ControllerState` (joints, motion state and mode, faults, command
buffer and plan, servo target, F/T sensor and contact scene, reduced mode, force, velocity and online control,
trajectories, the less common registers), its :class:`~.core.settings.Settings` (registers 31-79), and
one state object per component (IO, the tool RS-485 bridge's timeouts, the xArm gripper, the
device on the tool bus, vacuum and Lite 6 grippers, linear track, thermal model), the Modbus-TCP
user storage, the feedback queue of firmware 2.x and the pending scheduled actions. Everything
else an :class:`~.emulator.Emulator` holds is fixed at construction (model, firmware, serial
numbers, wiring between components) or derived from this tree (caches);
``tests/test_state_tree.py`` walks the emulator and checks it.

A checkpoint is this tree copied as a whole, and restoring one hands every part back to its
component as a whole (:meth:`~.emulator.Emulator.restore`), like MuJoCo's ``mjData`` beside the
constant ``mjModel``.

Adding a component's state takes five edits: declare its dataclass beside the component, decorate
the component with :func:`~.core.controller_state.holds` and set ``self.data`` first thing in its
``__init__``, give :class:`EmulatorState` a field for it (``None`` when the component is optional),
and name the field in :meth:`~.emulator.Emulator.state` and in ``Emulator._adopt`` (with any wiring
the component needs again after a restore, as the vacuum and Lite 6 grippers take the IO's tool
board back); ``tests/test_state_tree.py`` fails until each is done.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..protocol.modbus import POINTS
from .core.controller_state import ControllerState
from .core.feedback import FeedbackState
from .core.settings import Settings
from .core.thermal import ThermalState
from .devices.bio_gripper import BioGripperState
from .devices.gripper import ToolBusState, XArmGripperState
from .devices.inspire_hand import HandState
from .devices.io import IOState
from .devices.linear_track import LinearTrackState
from .devices.lite6_gripper import Lite6GripperState
from .devices.robotiq import RobotiqState
from .devices.vacuum import VacuumState

if TYPE_CHECKING:  # the physics world imports its engine (an extra) only for a scene with objects
    from .physics.world import PhysicsState


def _zeros(point: str) -> Callable[[], list[int]]:
    return lambda: [0] * POINTS[point].count


@dataclass(slots=True)
class ModbusUserState:
    """What a Modbus-TCP client stores in the box (the standard Modbus map's user coils and
    registers, section 2.2): kept per box, lost at power-off (register 40 does not save them),
    and the Blockly / G-code trigger values with every trigger written, in order."""

    user_coils: list[int] = field(default_factory=_zeros("user_coils"))
    user_registers: list[int] = field(default_factory=_zeros("user_registers"))
    blockly_trigger: list[int] = field(default_factory=_zeros("blockly_trigger"))
    gcode_trigger: list[int] = field(default_factory=lambda: [0])
    #: Every trigger written: ("blockly" | "gcode", "%05d" name).
    triggered: list[tuple[str, str]] = field(default_factory=list)


@dataclass(slots=True)
class Schedule:
    """Actions to run at a controller time (:meth:`~.emulator.Emulator.at`, a fault schedule): a
    heap of (time s, sequence number, action) and the last sequence number given. A checkpoint
    holds the actions still pending then, so a restore puts the schedule back where it was."""

    heap: list[tuple[float, int, Callable[[], object]]] = field(default_factory=list)
    seq: int = 0


#: What may sit on the tool RS-485 beside the xArm gripper (controller/emulator.py ``tool_device``).
ToolDeviceState = RobotiqState | BioGripperState | HandState


@dataclass(slots=True)
class EmulatorState:
    """Every mutable value of one emulated control box (see the module docstring)."""

    controller: ControllerState
    settings: Settings
    io: IOState
    tool_bus: ToolBusState
    xarm_gripper: XArmGripperState
    thermal: ThermalState
    modbus: ModbusUserState
    schedule: Schedule
    #: The device on the tool bus (Robotiq 2F-85/2F-140, BIO G2 or G1, Inspire RH56 hand), when one is
    #: attached instead of the xArm gripper.
    tool_device: ToolDeviceState | None = None
    vacuum: VacuumState | None = None
    lite6_gripper: Lite6GripperState | None = None
    linear_track: LinearTrackState | None = None
    #: The feedback queue of firmware 2.x (registers 253/254 and the 0xFF frames' events).
    feedback: FeedbackState | None = None
    #: The physics world of a scene with objects (:mod:`.physics`): captured from the engine as a
    #: value (``World.capture``) and put back with ``World.restore``.
    physics: PhysicsState | None = None

    def layout(self) -> tuple[type | None, ...]:
        """Which optional parts the box has, by type: two states of one layout fit one emulator."""
        return tuple(None if x is None else type(x)
                     for x in (self.tool_device, self.vacuum, self.lite6_gripper, self.linear_track,
                               self.feedback, self.physics))
