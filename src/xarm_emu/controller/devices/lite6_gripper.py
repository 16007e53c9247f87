"""The Lite 6 gripper: pneumatic jaws on two tool outputs (manual section 2.1.4, registers 127/128,
tool address 0x0A15).

The SDK's ``open_lite6_gripper``, ``close_lite6_gripper`` and ``stop_lite6_gripper`` write TO0/TO1
(:class:`~xarm_emu.model.robots.PneumaticGripper`: open (1, 0), close (0, 1), stop (0, 0)); the
gripper has no register, no position and no status readback, so only the outputs (0x0A18) show what
was asked. The emulator keeps the jaw state for tests and the admin channel:

- ``opening`` runs from 0.0 (closed) to 1.0 (open) at a constant rate, one full stroke taking
  :data:`TRAVEL_TIME` seconds (the emulator's choice: a small pneumatic gripper needs some tenths
  of a second; the vendor publishes no figure);
- ``jaw`` is ``"open"`` / ``"closed"`` at the ends, ``"opening"`` / ``"closing"`` on the way, and
  ``"stopped"`` when "stop" (or an output combination no command sets, both on) left it between
  the ends. The power-on outputs are (0, 0): the jaws start open.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

from ...model.robots import PneumaticGripper
from ...protocol.regmap import RegisterMap
from ..core.controller_state import holds
from ..core.device import NO_REGISTERS
from ..core.interface import NOT_IDLE, ControllerView
from .io import ToolIO

TRAVEL_TIME = 0.3  # s for a full stroke, either way

JAW_OPEN = "open"
JAW_CLOSED = "closed"
JAW_OPENING = "opening"
JAW_CLOSING = "closing"
JAW_STOPPED = "stopped"


@dataclass(slots=True)
class Lite6GripperState:
    """How far the jaws are open: 0 closed .. 1 open."""

    opening: float = 1.0


@holds(Lite6GripperState)
class Lite6Gripper:
    """Controller component: the Lite 6 gripper's jaws, following the TO0/TO1 command; a device
    (:class:`~..core.device.Device`) without registers or an error code of its own."""

    REGISTER_MAP: ClassVar[RegisterMap] = NO_REGISTERS
    error = 0  # no error code of its own

    def __init__(self, tool: ToolIO, spec: PneumaticGripper | None = None) -> None:
        self.data = Lite6GripperState()
        self.tool = tool
        self.spec = spec or PneumaticGripper()
        self.opening = 1.0  # 0 closed .. 1 open

    @property
    def command(self) -> str | None:
        """The command the tool outputs now give (``"open"``, ``"close"``, ``"stop"``, or None)."""
        return self.spec.command(self.tool.output(0), self.tool.output(1))

    @property
    def jaw(self) -> str:
        """The jaw state: where the jaws are and where the outputs now drive them."""
        if self.opening >= 1.0:
            return JAW_OPEN if self.command != "close" else JAW_CLOSING
        if self.opening <= 0.0:
            return JAW_CLOSED if self.command != "open" else JAW_OPENING
        return {"open": JAW_OPENING, "close": JAW_CLOSING}.get(self.command or "", JAW_STOPPED)

    def inject_error(self, code: int) -> None:
        raise ValueError("the Lite 6 gripper has no error code of its own")

    def clear_error(self) -> None:
        pass

    def status_fields(self) -> dict[str, Any]:
        return {"jaw": self.jaw, "opening": round(self.opening, 3)}

    def step(self, dt: float, ctl: ControllerView) -> None:
        cmd = self.command
        rate = dt / TRAVEL_TIME
        if cmd == "open":
            self.opening = self.opening + rate
        elif cmd == "close":
            self.opening = self.opening - rate
        # A stroke of TRAVEL_TIME / PERIOD periods ends exactly at an end, not a rounding short of it.
        self.opening = 0.0 if self.opening < 1e-9 else 1.0 if self.opening > 1.0 - 1e-9 else self.opening

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle (:func:`~..core.interface.idle_until`) while the jaws rest: at the end the command drives them
        to, or held between the ends."""
        o, cmd = self.opening, self.command
        if cmd == "open":
            return math.inf if o == 1.0 else NOT_IDLE
        if cmd == "close":
            return math.inf if o == 0.0 else NOT_IDLE
        return math.inf if o in (0.0, 1.0) or 1e-9 <= o <= 1.0 - 1e-9 else NOT_IDLE
