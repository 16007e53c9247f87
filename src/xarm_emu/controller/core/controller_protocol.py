"""What handlers, devices and applications may use of the controller: the :class:`Controller`
protocol, declared here below them so that none of them imports the controller itself
(``controller/controller.py``, which binds the handlers and steps the applications).

The controller's class satisfies it; mypy checks that wherever the controller is handed on. The
names are the controller's: its constant robot model, firmware and register table, its mutable
state (:class:`~.controller_state.ControllerState`, with the fields the controller also shows by
name: ``ctl.q`` is ``ctl.data.q``), its settings (registers 31-79), the command buffer's executor,
and what it offers: poses, readiness checks, the buffer, faults and the state machine's stops.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol

import numpy as np

from ...model import collision
from ...model.robots import RobotModel
from ...protocol.firmware import FirmwareProfile
from ...protocol.registers import Register
from ..motion import ServoTracker
from .commands import QueuedCommand, Task
from .controller_state import ControllerState
from .executor import Executor, Limits
from .faults import Faults
from .interface import Handler, Hooks
from .settings import Settings
from .state_machine import MODE_POSITION


class Component(Protocol):
    """A controller part with its own state that steps with the controller after each control
    period. Its registers, if any, are rows of the binding table naming its class
    (:class:`~.interface.Binding`)."""

    def step(self, dt: float, ctl: Controller) -> None: ...


class Controller(Protocol):
    """One control box with its arm, as its parts see it."""

    # -- constant wiring -----------------------------------------------------------------------
    model: RobotModel
    firmware: FirmwareProfile
    registers: Mapping[int, Register]  # the register table of the box's firmware
    dof: int
    period: float  # the control period, s
    robot_sn: str
    box_sn: str
    hooks: Hooks
    executor: Executor
    components: list[Component]

    # -- mutable state ---------------------------------------------------------------------------
    data: ControllerState
    settings: Settings
    # fields of ``data`` the controller shows by name
    motion_state: int  # register 13
    steps: int
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    mode: int  # register 19
    enabled: list[bool]  # register 11
    brakes: list[bool]  # register 18
    faults: Faults
    servo_target: np.ndarray | None
    servo_tracker: ServoTracker | None
    simulation_robot: bool  # register 79
    collision_tool: collision.ToolModel  # register 78
    user_counter: int  # registers 74/75

    @property
    def time(self) -> float: ...

    @property
    def state(self) -> int: ...

    @property
    def is_moving(self) -> bool: ...

    @property
    def ready(self) -> bool: ...

    @property
    def tcp_position(self) -> tuple[float, float, float]: ...

    @property
    def error_code(self) -> int: ...

    @error_code.setter
    def error_code(self, code: int) -> None: ...

    @property
    def warning_code(self) -> int: ...

    @warning_code.setter
    def warning_code(self, code: int) -> None: ...

    @property
    def servo_errors(self) -> list[int]: ...

    @servo_errors.setter
    def servo_errors(self, codes: list[int]) -> None: ...

    # -- what it offers --------------------------------------------------------------------------
    def version_string(self) -> str: ...

    def status_byte(self) -> int: ...

    def tcp_matrix(self, q: np.ndarray | None = None) -> np.ndarray: ...

    def tcp_pose(self) -> np.ndarray: ...

    def flange_target(self, T_tcp_user: np.ndarray) -> np.ndarray: ...

    def joints7(self, q: np.ndarray | None = None) -> tuple[float, ...]: ...

    def limits(self) -> Limits: ...

    def joint_torques(self) -> np.ndarray: ...

    def joint_torques7(self) -> tuple[float, ...]: ...

    def handler_of(self, code: int) -> Handler: ...

    def config_values(self) -> dict[str, Any]: ...

    def add_component(self, component: Component) -> None: ...

    def raise_error(self, code: int) -> None: ...

    def raise_warning(self, code: int) -> None: ...

    def require_motion_allowed(self, servo: bool = False) -> None: ...

    def queue(self, cmd: QueuedCommand) -> dict[str, Any]: ...

    def system_reset(self) -> None: ...

    def enter_stop(self) -> None: ...

    def ft_sensor_in_use(self) -> bool: ...


def queue_behind_moves(ctl: Controller, register: int, run: Callable[[], None]) -> None:
    """Run a non-motion task in its turn in the command buffer: at once when nothing is queued or
    moving (or the arm is not in position mode), otherwise when the buffer reaches it."""
    ex = ctl.executor
    if ctl.mode == MODE_POSITION and ex.active and not ex.stopping and ctl.error_code == 0:
        ctl.queue(Task(register, run))
    else:
        run()
