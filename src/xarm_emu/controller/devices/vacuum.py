"""The xArm Vacuum Gripper on the tool IO (manual chapter 4, accessory table: digital IO, feedback
"air pressure (low or normal)").

It has no register of its own: the SDK's ``set_vacuum_gripper`` drives two tool outputs and reads
"pressure normal" on a tool input, waiting until it matches. Two wirings exist (the SDK's
``hardware_version``, :data:`~xarm_emu.model.robots.VACUUM_WIRING`): 1 runs the pump with TO0 = 1,
TO1 = 0 and releases with TO0 = 0, TO1 = 1, reporting on TI0; 2 does the same on TO3/TO4 and
reports on TI3. ``get_vacuum_gripper(check_on=True)`` first reads the outputs back at tool address
0x0A18 (controller/devices/io.py). Without a model the input never rises and every
``set_vacuum_gripper(True, wait=True)`` times out, so the emulator can attach one
(``Emulator(vacuum=True)``, ``serve --vacuum``); it answers on both wirings, each with its own
pressure switch:

- the input rises :data:`PRESSURE_BUILD` seconds after the pump starts while an object seals the cup,
  and falls :data:`PRESSURE_RELEASE` seconds after the pump stops or releases;
- an object is at the cup unless a test says otherwise (``set_input("vacuum-object", 0, 0)``, a
  missed pick or a dropped part); without one the pressure never becomes normal, and losing the
  object drops the input at once.

While the model is attached it owns TI0 and TI3 (TI1, TI2 and TI4 stay free for sensors). The
delays are the emulator's; the vendor publishes none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

from ...model.robots import VACUUM_WIRING, VacuumWiring
from ...protocol.regmap import RegisterMap
from ..core.controller_state import holds
from ..core.device import NO_REGISTERS
from ..core.interface import NOT_IDLE, ControllerView
from .io import ToolIO

PRESSURE_BUILD = 0.3  # s from pump on (object present) to the pressure input = 1
PRESSURE_RELEASE = 0.2  # s from pump off / release to the pressure input = 0

#: Tool output name -> bit of the 0x0A15 / 0x0A18 word (the SDK's ``tgpio_set_digital`` masks).
OUTPUT_BITS = {"TO0": 0, "TO1": 1, "TO2": 4, "TO3": 2, "TO4": 3}


def _input_number(name: str) -> int:
    return int(name.removeprefix("TI"))


@dataclass(slots=True)
class VacuumState:
    """Whether an object seals the cup, and how long each wiring's pressure has been heading where
    it now heads (s, by hardware version)."""

    object_present: bool = True
    _since: dict[int, float] = field(default_factory=lambda: {version: 0.0 for version in VACUUM_WIRING})


@holds(VacuumState)
class VacuumGripper:
    """Controller component: the vacuum gripper's pressure switch, driven through either wiring; a
    device (:class:`~..core.device.Device`) without registers or an error code of its own."""

    REGISTER_MAP: ClassVar[RegisterMap] = NO_REGISTERS
    error = 0  # no error code of its own

    def __init__(self, tool: ToolIO) -> None:
        self.data = VacuumState()
        #: The tool IO board the pump and the pressure switch are wired to (the IO component's).
        self.tool = tool
        self.object_present = True
        self._since = {version: 0.0 for version in VACUUM_WIRING}

    def pumping_on(self, version: int) -> bool:
        """The pump runs through wiring ``version`` (its outputs at their "on" values)."""
        w = VACUUM_WIRING[version]
        outs = tuple(self.tool.output(OUTPUT_BITS[name]) for name in w.outputs)
        return outs == w.on

    def pressure_on(self, version: int) -> bool:
        """The pressure input of wiring ``version`` reads "normal"."""
        return self.tool.input(_input_number(VACUUM_WIRING[version].object_input)) == 1

    @property
    def pumping(self) -> bool:
        """The pump runs through the plug-in wiring (hardware version 1)."""
        return self.pumping_on(1)

    @property
    def pressure_normal(self) -> bool:
        """TI0 (hardware version 1) reads "pressure normal"."""
        return self.pressure_on(1)

    def _step_wiring(self, version: int, w: VacuumWiring, dt: float) -> None:
        want = self.pumping_on(version) and self.object_present
        if want == self.pressure_on(version):
            self._since[version] = 0.0
            return
        self._since[version] += dt
        delay = PRESSURE_BUILD if want else (0.0 if not self.object_present else PRESSURE_RELEASE)
        if self._since[version] >= delay - 1e-9:
            self.tool.set_input(_input_number(w.object_input), 1 if want else 0)
            self._since[version] = 0.0

    def inject_error(self, code: int) -> None:
        raise ValueError("the vacuum gripper has no error code of its own")

    def clear_error(self) -> None:
        pass

    def status_fields(self) -> dict[str, Any]:
        return {"pumping": self.pumping, "pressure_normal": self.pressure_normal,
                "object": self.object_present}

    def step(self, dt: float, ctl: ControllerView) -> None:
        for version, w in VACUUM_WIRING.items():
            self._step_wiring(version, w, dt)

    def idle_until(self, ctl: ControllerView) -> float:
        """Idle (:func:`~..core.interface.idle_until`) while every wiring's pressure input reads what its pump
        and the object give."""
        for version in VACUUM_WIRING:
            want = self.pumping_on(version) and self.object_present
            if want != self.pressure_on(version) or self._since[version] != 0.0:
                return NOT_IDLE
        return math.inf
