"""Parameter and configuration registers (manual 2.1.3, registers 5, 31-40, 51-59, 70-79)."""

from __future__ import annotations

from typing import Any

from ..model import collision
from .base import (
    Handler,
    ParameterError,
    Values,
)
from .core import (
    ControllerCore,
)
from .settings import (
    COLLISION_SENSITIVITY_RANGE,
    MOTION_LIMITS,
    TEACH_SENSITIVITY_RANGE,
    Settings,
    boundary_ok,
    gravity_ok,
    in_range,
)
from .states import Event, fire


class SettingCommands(ControllerCore):
    """Registers 5, 31-40, 51, 52, 59, 70, 73, 77-79."""

    def register_handlers(self) -> dict[int, Handler]:
        h = super().register_handlers()
        h.update({
            5: lambda v: {"tau_or_i": int(self.settings.report_current)},
            31: self._setter("tcp_jerk", "jerk"),
            32: self._setter("tcp_maxacc", "maxacc"),
            33: self._setter("joint_jerk", "jerk"),
            34: self._setter("joint_maxacc", "maxacc"),
            35: self._h_tcp_offset,
            36: self._h_tcp_load,
            37: self._sensitivity("collision_sensitivity", COLLISION_SENSITIVITY_RANGE),
            38: self._sensitivity("teach_sensitivity", TEACH_SENSITIVITY_RANGE),
            39: self._h_clean_conf,
            40: self._h_save_conf,
            51: self._h_gravity,
            52: self._h_boundary,
            59: self._h_boundary_on,
            70: self._h_report_tau_or_i,
            73: self._h_world_offset,
            77: self._h_self_collision,
            78: self._h_collision_tool,
            79: self._h_simulation_robot,
        })
        return h

    # parameters
    def _setter(self, name: str, key: str) -> Handler:
        """Registers 31-34: a jerk or maximum acceleration within Table 1.2 (manual 1.3), above 0:
        the table's lower bound 0 would leave no motion to plan, so it is refused like any value out
        of range (warning 12)."""
        hi = getattr(self.model, MOTION_LIMITS[name])

        def set_value(v: Values) -> dict[str, Any]:
            value = v[key]
            if not (in_range(value, hi) and value > 0.0):
                raise ParameterError(f"{name} outside Table 1.2 or zero")
            setattr(self.settings, name, float(value))
            return {"cmdnum": self.executor.cmdnum}

        return set_value

    def _h_tcp_offset(self, v: Values) -> None:
        self.settings.tcp_offset = [float(x) for x in v["pose"]]
        self.system_reset()
        return None

    def _h_tcp_load(self, v: Values) -> None:
        """Register 36 (manual 2.1.4, end payload setting): mass in kg, centre of mass in mm.

        Within the model's rated payload and centre-of-mass bound, or warning 12.
        """
        m = self.model
        if not 0.0 <= v["mass"] <= m.rated_payload:
            raise ParameterError(f"payload mass is 0..{m.rated_payload} kg")
        if any(abs(c) > m.payload_com_limit for c in v["center"]):
            raise ParameterError(f"payload centre of mass is within +/-{m.payload_com_limit} mm")
        self.settings.tcp_load = [float(v["mass"]), *(float(x) for x in v["center"])]
        return None

    def _sensitivity(self, name: str, allowed: tuple[int, int]) -> Handler:
        """Registers 37 and 38: a sensitivity level within ``allowed``; a system reset (section 1.5)."""
        lo, hi = allowed

        def set_level(v: Values) -> None:
            if not lo <= v["sensitivity"] <= hi:
                raise ParameterError(f"{name.replace('_', ' ')} is {lo}..{hi}")
            setattr(self.settings, name, int(v["sensitivity"]))
            self.system_reset()
            return None

        return set_level

    def _h_clean_conf(self, v: Values) -> None:
        self.settings = Settings.for_model(self.model)
        if self.hooks.on_clean_conf is not None:
            self.hooks.on_clean_conf()
        return None

    def _h_save_conf(self, v: Values) -> None:
        if self.hooks.on_save is not None:
            self.hooks.on_save(self.config_values())
        return None

    def _h_world_offset(self, v: Values) -> None:
        self.settings.world_offset = [float(x) for x in v["pose"]]
        self.system_reset()
        return None

    # other settings
    def _h_gravity(self, v: Values) -> None:
        if not gravity_ok(v["direction"]):
            raise ParameterError("gravity direction must be a non-zero finite vector")
        self.settings.gravity_direction = [float(x) for x in v["direction"]]
        return None

    def _h_boundary(self, v: Values) -> None:
        b = [int(x) for x in v["boundary"]]
        if not boundary_ok(b):
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
        raw = v.get("params", ())
        params = [float(x) for x in (raw if isinstance(raw, tuple) else (raw,))]  # one value: a scalar
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
            self.executor.discard()
            self.servo_target = None
            self.servo_tracker = None
            if self._physical_q is not None:
                self.q = self._physical_q
            self._physical_q = None
            fire(self, Event.VIRTUAL_OFF)
        self.simulation_robot = on
        return None
