"""Parameter and configuration registers (manual section 2.1.3, registers 5, 31-40, 51-59, 70-79)."""

from __future__ import annotations

import functools
from typing import Any

from ...model import collision
from ..core.controller_protocol import Controller, queue_behind_moves
from ..core.interface import Binding, ParameterError, Values
from ..core.settings import (
    COLLISION_SENSITIVITY_RANGE,
    MOTION_LIMITS,
    TEACH_SENSITIVITY_RANGE,
    Settings,
    boundary_ok,
    gravity_ok,
    in_range,
)
from ..core.state_machine import Event, fire


def motion_limit(ctl: Controller, v: Values, *, name: str, key: str) -> dict[str, Any]:
    """Registers 31-34: a jerk or maximum acceleration within Table 1.2 (manual 1.3), above 0:
    the table's lower bound 0 would leave no motion to plan, so it is refused like any value out
    of range (warning 12)."""
    value = v[key]
    if not (in_range(value, getattr(ctl.model, MOTION_LIMITS[name])) and value > 0.0):
        raise ParameterError(f"{name} outside Table 1.2 or zero")
    setattr(ctl.settings, name, float(value))
    return {"cmdnum": ctl.executor.cmdnum}


def sensitivity(ctl: Controller, v: Values, *, name: str, allowed: tuple[int, int]) -> None:
    """Registers 37 and 38: a sensitivity level within ``allowed``; a system reset (section 1.5)."""
    lo, hi = allowed
    if not lo <= v["sensitivity"] <= hi:
        raise ParameterError(f"{name.replace('_', ' ')} is {lo}..{hi}")
    setattr(ctl.settings, name, int(v["sensitivity"]))
    ctl.system_reset()
    return None


def tcp_offset(ctl: Controller, v: Values) -> None:
    """Register 35: the TCP offset; a system reset."""
    ctl.settings.tcp_offset = [float(x) for x in v["pose"]]
    ctl.system_reset()
    return None


def tcp_load(ctl: Controller, v: Values) -> None:
    """Register 36 (manual 2.1.4, end payload setting): mass in kg, centre of mass in mm.

    Within the model's rated payload and centre-of-mass bound, or warning 12. Firmware 2.x
    (:attr:`~xarm_emu.protocol.firmware.FirmwareProfile.payload_queued`) applies it in its turn in
    the command buffer, after the moves queued before it (its TRIGGER feedback then); the manual's
    box applies it at once.
    """
    m = ctl.model
    if not 0.0 <= v["mass"] <= m.rated_payload:
        raise ParameterError(f"payload mass is 0..{m.rated_payload} kg")
    if any(abs(c) > m.payload_com_limit for c in v["center"]):
        raise ParameterError(f"payload centre of mass is within +/-{m.payload_com_limit} mm")
    load = [float(v["mass"]), *(float(x) for x in v["center"])]
    if ctl.firmware.payload_queued:
        queue_behind_moves(ctl, 36, functools.partial(_apply_tcp_load, ctl, load))
    else:
        _apply_tcp_load(ctl, load)
    return None


def _apply_tcp_load(ctl: Controller, load: list[float]) -> None:
    ctl.settings.tcp_load = list(load)


def clean_conf(ctl: Controller, v: Values) -> None:
    """Register 39: settings back to the defaults (and the saved file, through the hooks)."""
    ctl.settings = Settings.for_model(ctl.model)
    if ctl.hooks.on_clean_conf is not None:
        ctl.hooks.on_clean_conf()
    return None


def save_conf(ctl: Controller, v: Values) -> None:
    """Register 40: save the settings (through the hooks)."""
    if ctl.hooks.on_save is not None:
        ctl.hooks.on_save(ctl.config_values())
    return None


def world_offset(ctl: Controller, v: Values) -> None:
    """Register 73: the user coordinate offset; a system reset."""
    ctl.settings.world_offset = [float(x) for x in v["pose"]]
    ctl.system_reset()
    return None


def gravity(ctl: Controller, v: Values) -> None:
    """Register 51: the gravity direction, a non-zero finite vector."""
    if not gravity_ok(v["direction"]):
        raise ParameterError("gravity direction must be a non-zero finite vector")
    ctl.settings.gravity_direction = [float(x) for x in v["direction"]]
    return None


def boundary(ctl: Controller, v: Values) -> None:
    """Register 52: the safety boundary (x, y, z maxima and minima)."""
    b = [int(x) for x in v["boundary"]]
    if not boundary_ok(b):
        raise ParameterError("boundary maxima must not be below minima")
    ctl.settings.boundary = b
    return None


def _switch(v: Values) -> bool:
    if v["on"] not in (0, 1):
        raise ParameterError("switch is 0 or 1")
    return bool(v["on"])


def boundary_on(ctl: Controller, v: Values) -> None:
    """Register 59: the safety boundary switch."""
    ctl.settings.boundary_on = _switch(v)
    return None


def report_tau_or_i(ctl: Controller, v: Values) -> None:
    """Registers 70 (and 24's one-byte form): reports carry torques (0) or currents (1)."""
    value = v["tau_or_i"]
    if value not in (0, 1):
        raise ParameterError("0: torque, 1: current")
    ctl.settings.report_current = bool(value)
    return None


def self_collision(ctl: Controller, v: Values) -> None:
    """Register 77: the self-collision detection switch."""
    ctl.settings.self_collision_on = _switch(v)
    return None


def collision_tool(ctl: Controller, v: Values) -> None:
    """Register 78: the end tool's geometry for self-collision detection (model/collision.py)."""
    raw = v.get("params", ())
    params = [float(x) for x in (raw if isinstance(raw, tuple) else (raw,))]  # one value: a scalar
    try:
        tool = collision.tool_model(int(v["tool_type"]), params)
    except ValueError as exc:
        raise ParameterError(str(exc)) from exc
    ctl.collision_tool = tool
    ctl.settings.collision_tool = [float(tool.kind), *params, *([0.0] * (6 - len(params)))][:7]
    return None


def simulation_robot(ctl: Controller, v: Values) -> None:
    """Register 79, virtual robot mode: while on, the reported arm follows the commands and the
    physical arm stays where it was; switching it off ends motion and reports the physical arm
    again."""
    on = _switch(v)
    data = ctl.data
    if on and not data.simulation_robot:
        data.physical_q = data.q.copy()
    elif not on and data.simulation_robot:
        ctl.executor.discard()
        data.servo_target = None
        data.servo_tracker = None
        if data.physical_q is not None:
            data.q = data.physical_q
        data.physical_q = None
        fire(ctl, Event.VIRTUAL_OFF)
    data.simulation_robot = on
    return None


def get_tau_or_i(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 5: whether the reports carry joint currents (1) or torques (0)."""
    return {"tau_or_i": int(ctl.settings.report_current)}


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(5, get_tau_or_i),
    Binding(31, functools.partial(motion_limit, name="tcp_jerk", key="jerk")),
    Binding(32, functools.partial(motion_limit, name="tcp_maxacc", key="maxacc")),
    Binding(33, functools.partial(motion_limit, name="joint_jerk", key="jerk")),
    Binding(34, functools.partial(motion_limit, name="joint_maxacc", key="maxacc")),
    Binding(35, tcp_offset),
    Binding(36, tcp_load),
    Binding(37, functools.partial(sensitivity, name="collision_sensitivity",
                                  allowed=COLLISION_SENSITIVITY_RANGE)),
    Binding(38, functools.partial(sensitivity, name="teach_sensitivity", allowed=TEACH_SENSITIVITY_RANGE)),
    Binding(39, clean_conf),
    Binding(40, save_conf),
    Binding(51, gravity),
    Binding(52, boundary),
    Binding(59, boundary_on),
    Binding(70, report_tau_or_i),
    Binding(73, world_offset),
    Binding(77, self_collision),
    Binding(78, collision_tool),
    Binding(79, simulation_robot),
)
