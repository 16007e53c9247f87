"""The controller's mutable state as one data object, beside the constant robot model and the
settings (registers 31-79, :mod:`.settings`).

:class:`ControllerState` holds every value that changes while the box runs: the clock, the joints,
the motion state and mode (registers 13 and 19), enable and brake switches (registers 11 and 18),
the fault group (chapter 3), the servo target (registers 29, 30, 93), virtual robot mode (register 79),
the collision tool (register 78) and the command buffer with its running plan (:class:`PlanState`,
section 2.1.3 "command buffer"). Copying it (with the settings and the components) copies the whole
control box; derived values such as cached poses and torques are not part of it.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from operator import attrgetter
from typing import TYPE_CHECKING, Any, Generic, TypeVar, cast, overload

import numpy as np

from ...model import collision
from .faults import Faults
from .state_machine import MODE_POSITION, STATE_STOP

if TYPE_CHECKING:
    from ..motion import ServoTracker
    from .commands import QueuedCommand

#: The type of a part's own slot in :class:`ControllerState` (an application's, a device's, the F/T
#: configuration's): the part declares the type and reads the slot through its accessor, which
#: creates it on first use, so the core imports none of them. ``None`` until then.
Slot = object

T = TypeVar("T")
C = TypeVar("C", bound=type)

#: Shortest time to ramp the path rate between full speed and rest for suspend/stop (s); faster
#: motion ramps longer so that the deceleration stays within the acceleration limit.
RAMP_TIME = 0.2


@dataclass(slots=True)
class PlanState:
    """The command buffer and the motion that runs from it (:class:`~.executor.Executor`)."""

    #: Commands waiting, oldest first (the running one is :attr:`current`).
    buffer: deque[QueuedCommand] = field(default_factory=deque)
    #: The planned motion of the running command (an executor plan), or ``None``.
    plan: Any = None
    current: QueuedCommand | None = None
    t: float = 0.0  # path time within the current plan, s
    rate: float = 1.0  # path time per control time, 0..1
    ramp_from: float = 1.0
    ramp_to: float = 1.0
    ramp_u: float = 1.0  # progress of the current ramp, 0..1
    ramp_time: float = RAMP_TIME  # s
    stopping: bool = False  # a stop ramp is running; the plan ends when it reaches rest
    tcp_speed: float = 0.0  # mm/s
    merged: int = 0  # further commands of a blended chain that the current plan runs
    completed: int = 0  # commands run to their end (the report's command counter)

    @property
    def cmdnum(self) -> int:
        """Commands in the buffer, the running one included (register 14); 0 once a stop (state 4)
        discarded them, even while the arm is still coming to rest."""
        if self.stopping:
            return 0
        return len(self.buffer) + (1 + self.merged if self.current is not None else 0)


def part_of(data: ControllerState, slot: str, make: Callable[[], T]) -> T:
    """The application part in ``slot`` of ``data``, made by ``make`` when the slot is empty (at the
    controller's construction, so a checkpoint holds it from the start). Each application reads its
    part through this, with the slot's type given by ``make``."""
    part = getattr(data, slot)
    if part is None:
        part = make()
        setattr(data, slot, part)
    return cast(T, part)


@dataclass(slots=True)
class ControllerState:
    """Every mutable value of the controller core and its executor (see the module docstring).

    Slotted: a value that is not declared here cannot be attached at run time. The application
    states below start as None and are made by the module that owns them, mostly through
    :func:`part_of` (``reduced.reduced_of`` and the like): the controller's binding
    (``handlers.bind``) makes those of modes 4-7 and 11, trajectories and reduced mode
    (``applications.modes.create_state``), the less common registers, the F/T configuration and
    force control at construction; the emulator the F/T sensor's; the contact scene and the load
    identification stay None until they are set or run."""

    dof: int
    time: float = 0.0  # controller time, s
    steps: int = 0  # control periods since power-on
    q: np.ndarray = field(default_factory=lambda: np.zeros(0))  # joints, rad
    qd: np.ndarray = field(default_factory=lambda: np.zeros(0))  # rad/s
    qdd: np.ndarray = field(default_factory=lambda: np.zeros(0))  # rad/s^2
    #: Motion state (register 13); only :func:`.state_machine.fire` changes it.
    motion_state: int = STATE_STOP
    mode: int = MODE_POSITION  # register 19
    enabled: list[bool] = field(default_factory=list)  # register 11, per joint
    brakes: list[bool] = field(default_factory=list)  # True: brake released (motor holds the joint)
    faults: Faults = field(default_factory=Faults)
    #: Servo mode (registers 29, 30, 93): the joint target and the tracker that follows it.
    servo_target: np.ndarray | None = None
    servo_tracker: ServoTracker | None = None
    simulation_robot: bool = False  # register 79
    #: The physical arm's joints while virtual robot mode is on.
    physical_q: np.ndarray | None = None
    collision_tool: collision.ToolModel = collision.NO_TOOL  # register 78
    user_counter: int = 0  # registers 74/75, the counter of rich report bytes 285-288
    #: The joints where the last only-check move ended (the SDK's "intermediate state"), if kept.
    check_q: np.ndarray | None = None
    motion: PlanState = field(default_factory=PlanState)
    #: The F/T sensor (controller/devices/ft_sensor.py: mounted, switched on, wrenches, readings).
    ft_sensor: Slot = None  # FtSensorState
    #: The contact scene (controller/scene/contact.py), fixed in the base frame.
    contact_scene: Slot = None  # Scene
    #: The F/T configuration registers 201-208 (controller/handlers/ft_sensor.py).
    ft_config: Slot = None  # FtConfig
    #: Force control and impedance control (register 202, controller/applications/force_control.py).
    force_control: Slot = None  # ForceControl
    #: Reduced mode and its limits (registers 47-50, 53, 58, 60, controller/applications/reduced.py).
    reduced: Slot = None  # ReducedMode
    #: Velocity control (modes 4 and 5, controller/applications/velocity.py).
    velocity_control: Slot = None  # VelocityControl
    #: The online planner (modes 6 and 7, controller/applications/online.py).
    online_planner: Slot = None  # OnlinePlanner
    #: Trajectory recording and playback (registers 61-65 and 230, controller/applications/trajectory.py).
    trajectory_store: Slot = None  # TrajectoryStore
    #: The less common registers' values (controller/handlers/service.py).
    extra_state: Slot = None  # ExtraState
    #: The load identification of register 204 under way or last run (:mod:`..applications.identification`).
    identification: Slot = None  # Identification

    @classmethod
    def initial(cls, dof: int) -> ControllerState:
        """A box of ``dof`` joints at power-on: at zero, enabled, brakes released, state 4."""
        return cls(dof, q=np.zeros(dof), qd=np.zeros(dof), qdd=np.zeros(dof), enabled=[True] * dof,
                   brakes=[True] * dof, faults=Faults.none(dof))


class StateField(Generic[T]):
    """A value of the owner's ``data`` (a :class:`ControllerState`), read and written by the same
    name on the owner: ``ctl.q`` is ``ctl.data.q``."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, obj: None, owner: type) -> StateField[T]: ...
    @overload
    def __get__(self, obj: object, owner: type) -> T: ...
    def __get__(self, obj: object | None, owner: type) -> StateField[T] | T:
        if obj is None:
            return self
        value: T = getattr(obj.data, self.name)  # type: ignore[attr-defined]
        return value

    def __set__(self, obj: object, value: T) -> None:
        setattr(obj.data, self.name, value)  # type: ignore[attr-defined]


def _field_property(name: str) -> property:
    """``self.<name>`` read and written as ``self.data.<name>``. The getter is an ``attrgetter``
    (C code, no Python frame): components read their values every control period, and a
    :class:`StateField` there cost the idle arm's step about a fifth more."""

    def write(obj: Any, value: Any) -> None:
        setattr(obj.data, name, value)

    return property(attrgetter(f"data.{name}"), write)


def holds(state_type: type) -> Callable[[C], C]:
    """Class decorator of a component whose mutable values are one ``state_type`` dataclass in
    ``self.data``: every field of it becomes a property of the class, so the component's code
    reads and writes ``self.position`` while the value lives in ``self.data.position``, and a
    checkpoint (the emulator's state tree, controller/box_state.py) holds ``self.data`` whole.
    The component sets ``self.data`` first thing in ``__init__``; attributes that are not fields
    (references to other objects, fixed configuration) stay plain attributes."""

    def decorate(cls: C) -> C:
        for f in fields(state_type):
            setattr(cls, f.name, _field_property(f.name))
        return cls

    return decorate
