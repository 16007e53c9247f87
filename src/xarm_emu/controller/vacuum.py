"""The xArm Vacuum Gripper on the tool IO (manual chapter 4, accessory table: digital IO, feedback
"air pressure (low or normal)").

It has no register of its own: the SDK's ``set_vacuum_gripper`` drives the tool outputs (TO0 = 1 and
TO1 = 0 run the pump, TO0 = 0 and TO1 = 1 release) and reads "pressure normal" on tool input TI0,
waiting until it matches (the SDK's ``gpio.py``). Without a model TI0 never
rises and every ``set_vacuum_gripper(True, wait=True)`` times out, so the emulator can attach one
(``Emulator(vacuum=True)``, ``serve --vacuum``):

- TI0 rises :data:`PRESSURE_BUILD` seconds after the pump starts while an object seals the cup,
  and falls :data:`PRESSURE_RELEASE` seconds after the pump stops or releases;
- an object is at the cup unless a test says otherwise (``set_input("vacuum-object", 0, 0)``, a
  missed pick or a dropped part); without one the pressure never becomes normal, and losing the
  object drops TI0 at once.

While the model is attached it owns TI0 (TI1 stays free for sensors). The delays are the
emulator's; the vendor publishes none.
"""

from __future__ import annotations

from .base import ControllerView, Handler
from .io import ToolIO

PRESSURE_BUILD = 0.3  # s from pump on (object present) to TI0 = 1
PRESSURE_RELEASE = 0.2  # s from pump off / release to TI0 = 0


class VacuumGripper:
    """Controller component: the vacuum gripper's pressure switch on TI0, driven by TO0/TO1."""

    def __init__(self, tool: ToolIO) -> None:
        self.tool = tool
        self.object_present = True
        self._since = 0.0  # how long the pressure has been heading where it now heads

    @property
    def pumping(self) -> bool:
        return self.tool.output(0) == 1 and self.tool.output(1) == 0

    @property
    def pressure_normal(self) -> bool:
        return bool(self.tool.digital_inputs & 1)

    def handlers(self) -> dict[int, Handler]:
        return {}

    def step(self, dt: float, ctl: ControllerView) -> None:
        want = self.pumping and self.object_present
        if want == self.pressure_normal:
            self._since = 0.0
            return
        self._since += dt
        delay = PRESSURE_BUILD if want else (0.0 if not self.object_present else PRESSURE_RELEASE)
        if self._since >= delay - 1e-9:
            ti = self.tool.digital_inputs
            self.tool.digital_inputs = (ti | 1) if want else (ti & ~1)
            self._since = 0.0
