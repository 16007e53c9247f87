"""Reduced-mode registers (47-50, 53, 58, 60). The mechanism is
:mod:`xarm_emu.controller.applications.reduced`."""

from __future__ import annotations

import math
from typing import Any

from ..applications.reduced import reduced_of
from ..core.controller_protocol import Controller
from ..core.interface import Binding, ParameterError, Values


def _switch(v: Values, name: str = "on") -> bool:
    on = int(v[name])
    if on not in (0, 1):
        raise ParameterError("switch is 0 or 1")
    return bool(on)


def set_tcp_speed(ctl: Controller, v: Values) -> None:
    """Register 47: reduced-mode maximum TCP speed (mm/s, up to the model's)."""
    speed = float(v["speed"])
    if not (0.0 < speed <= ctl.model.max_tcp_speed):
        raise ParameterError("reduced TCP speed outside (0, maximum]")
    reduced_of(ctl).tcp_speed = speed
    return None


def set_joint_speed(ctl: Controller, v: Values) -> None:
    """Register 48: reduced-mode maximum joint speed (rad/s, up to the model's)."""
    speed = float(v["speed"])
    if not (0.0 < speed <= ctl.model.max_joint_speed * (1 + 1e-6)):
        raise ParameterError("reduced joint speed outside (0, maximum]")
    reduced_of(ctl).joint_speed = min(speed, ctl.model.max_joint_speed)
    return None


def get_mode(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 49: whether reduced mode is on."""
    return {"on": int(reduced_of(ctl).on)}


def set_mode(ctl: Controller, v: Values) -> None:
    """Register 50: switch reduced mode."""
    reduced_of(ctl).on = _switch(v)
    return None


def get_state(ctl: Controller, v: Values) -> dict[str, Any]:
    """Register 53: on, the safety boundary (register 52), the TCP and joint speed maxima, the joint
    ranges, the fence switch (59) and the collision rebound (60); 79 bytes."""
    r = reduced_of(ctl)
    s = ctl.settings
    return {"on": int(r.on), "boundary": tuple(int(b) for b in s.boundary), "tcp_speed": r.tcp_speed,
            "joint_speed": r.joint_speed, "joint_ranges": tuple(r.joint_ranges),
            "fence": int(s.boundary_on), "rebound": int(r.rebound)}


def set_joint_ranges(ctl: Controller, v: Values) -> None:
    """Register 58: reduced joint ranges (J1 min, J1 max, ... rad); each range must overlap the
    joint's limits and is clipped to them."""
    values = [float(x) for x in v["joint_ranges"]]
    m = ctl.model
    out = list(reduced_of(ctl).joint_ranges)
    for i in range(ctl.dof):
        lo, hi = values[2 * i], values[2 * i + 1]
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi or lo >= m.upper[i] or hi <= m.lower[i]:
            raise ParameterError(f"reduced range of joint {i + 1} is empty or outside its limits")
        out[2 * i], out[2 * i + 1] = max(lo, float(m.lower[i])), min(hi, float(m.upper[i]))
    reduced_of(ctl).joint_ranges = out
    return None


def set_rebound(ctl: Controller, v: Values) -> None:
    """Register 60: switch the collision rebound (kept and reported in register 53)."""
    reduced_of(ctl).rebound = _switch(v)
    return None


#: The registers of this module, bound (:class:`~xarm_emu.controller.core.interface.Binding`).
BINDINGS: tuple[Binding, ...] = (
    Binding(47, set_tcp_speed),
    Binding(48, set_joint_speed),
    Binding(49, get_mode),
    Binding(50, set_mode),
    Binding(53, get_state),
    Binding(58, set_joint_ranges),
    Binding(60, set_rebound),
)
