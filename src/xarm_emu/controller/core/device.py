"""The device interface: what every device of ``controller/devices/`` declares, so that the box that
plugs them in (``controller/emulator.py``) treats them alike and knows nothing of any one of them.

A device is a controller component (:class:`~.controller_protocol.Component`) with its own state and
its own faults:

- ``REGISTER_MAP``: its own registers, address -> field (:mod:`xarm_emu.protocol.regmap`): the
  holding registers of a Modbus slave on an RS-485 bus (register 124), the tool IO board's addresses
  (registers 127/128); empty for a device without registers of its own (wired to the tool outputs
  and inputs, or answering the controller's registers through its ``BINDINGS`` rows only);
- ``data``: every value of it that changes, one dataclass (:func:`~.controller_state.holds`), a part
  of the state tree (``Emulator.state``, ``controller/box_state.py``);
- ``step(dt, ctl)``: one control period, after the motion of the period; ``idle_until(ctl)``: the
  controller time before which stepping it would change nothing (:func:`~.interface.idle_until`);
- ``error``, ``inject_error(code)``, ``clear_error()``: its own error or fault code (0: none), as
  the admin channel's ``inject`` and ``clear`` set them;
- ``status_fields()``: what the admin ``status`` answer and the 3D view show of it.

A device on the tool RS-485 adds what the gripper module asks of it
(:class:`~xarm_emu.controller.devices.gripper.ToolDevice`).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any, ClassVar, Protocol, runtime_checkable

from ...protocol.regmap import RegisterMap
from .interface import ControllerView

#: The ``REGISTER_MAP`` of a device without registers of its own.
NO_REGISTERS: RegisterMap = MappingProxyType({})


@runtime_checkable
class Device(Protocol):
    """One device of ``controller/devices/`` (module docstring)."""

    REGISTER_MAP: ClassVar[RegisterMap]

    @property
    def data(self) -> Any: ...

    def step(self, dt: float, ctl: ControllerView) -> None: ...

    def idle_until(self, ctl: ControllerView) -> float: ...

    @property
    def error(self) -> int: ...

    def inject_error(self, code: int) -> None: ...

    def clear_error(self) -> None: ...

    def status_fields(self) -> dict[str, Any]: ...
