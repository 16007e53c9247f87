"""Reduced mode (registers 47-50, 53, 58, 60): lower maxima for the TCP and joint speeds and
narrower joint ranges, switched on and off as a whole, and the collision rebound setting.

While reduced mode is on:

- queued moves run at no more than the reduced TCP speed (Cartesian moves) or the reduced joint
  speed (joint moves), and velocity control (modes 4/5) clips its velocities to them;
- a joint that leaves its reduced range stops the arm with C23 (joint angle exceeds the limit), where
  the control period started; a joint already outside may move back in.

The maxima start at the model's (manual 1.3, Table 1.2) and the ranges at its joint limits, so
reduced mode changes nothing until they are set. Register 53 reports them with the safety boundary
(register 52) and fence switch (59); register 40 saves them with the other settings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from ..core.controller_protocol import Controller
from ..core.controller_state import part_of
from ..core.interface import C_JOINT_LIMIT, CommandError


@dataclass(slots=True)
class ReducedMode:
    on: bool = False
    tcp_speed: float = 0.0  # mm/s
    joint_speed: float = 0.0  # rad/s
    #: J1 min, J1 max, ... J7 min, J7 max (rad).
    joint_ranges: list[float] = field(default_factory=list)
    rebound: bool = False


def reduced_of(ctl: Controller) -> ReducedMode:
    """The reduced-mode settings of ``ctl`` (the model's maxima and limits until set)."""
    m = ctl.model
    return part_of(ctl.data, "reduced", lambda: ReducedMode(
        tcp_speed=float(m.max_tcp_speed), joint_speed=float(m.max_joint_speed),
        joint_ranges=reduced_of_default(ctl)))


def speed_caps(ctl: Controller) -> tuple[float, float]:
    """(TCP mm/s, joint rad/s) speed caps of queued moves: the reduced maxima while reduced mode
    is on, else infinite."""
    r = cast("ReducedMode | None", ctl.data.reduced)
    if r is None or not r.on:
        return _NO_CAPS
    return r.tcp_speed, r.joint_speed


_NO_CAPS = (math.inf, math.inf)


def joint_range(ctl: Controller) -> tuple[np.ndarray, np.ndarray]:
    """Joint limits (rad), narrowed to the reduced ranges while reduced mode is on."""
    lo, hi = ctl.model.lower.copy(), ctl.model.upper.copy()
    r = cast("ReducedMode | None", ctl.data.reduced)
    if r is not None and r.on:
        rng = np.asarray(r.joint_ranges[: 2 * ctl.dof], dtype=float).reshape(-1, 2)
        lo, hi = np.maximum(lo, rng[:, 0]), np.minimum(hi, rng[:, 1])
    return lo, hi


def check_step(ctl: Controller, q_prev: np.ndarray) -> None:
    """Each control period that moved the arm: stop with C23 where a joint leaves its reduced range."""
    r = cast("ReducedMode | None", ctl.data.reduced)
    if r is None or not r.on:
        return
    lo, hi = joint_range(ctl)

    def excess(q: np.ndarray) -> np.ndarray:
        return np.maximum(lo - q, 0.0) + np.maximum(q - hi, 0.0)

    if np.any(excess(ctl.q) > excess(q_prev) + 1e-12):
        ctl.q = np.asarray(q_prev, dtype=float).copy()
        raise CommandError(C_JOINT_LIMIT, "a joint leaves its reduced-mode range")


#: Key of the reduced-mode settings in the saved configuration (register 40).
CONFIG_KEY = "reduced"


def config_of(ctl: Controller) -> dict[str, Any] | None:
    """What register 40 saves of reduced mode; None while every setting has its default."""
    r = cast("ReducedMode | None", ctl.data.reduced)
    if r is None:
        return None
    m = ctl.model
    default = ReducedMode(tcp_speed=float(m.max_tcp_speed), joint_speed=float(m.max_joint_speed),
                          joint_ranges=reduced_of_default(ctl))
    if r == default:
        return None
    return {"on": r.on, "tcp_speed": r.tcp_speed, "joint_speed": r.joint_speed,
            "joint_ranges": list(r.joint_ranges), "rebound": r.rebound}


def reduced_of_default(ctl: Controller) -> list[float]:
    """The model's joint limits as reduced ranges (J1 min, J1 max, ... padded to 7 joints)."""
    ranges: list[float] = []
    for lo, hi in zip(ctl.model.lower, ctl.model.upper, strict=True):
        ranges += [float(lo), float(hi)]
    return ranges + [0.0] * (14 - len(ranges))


def load_config(ctl: Controller, data: Any) -> None:
    """Apply saved reduced-mode settings; anything of the wrong shape or out of range keeps the
    defaults."""
    ctl.data.reduced = None
    if not isinstance(data, dict):
        return
    r = reduced_of(ctl)
    m = ctl.model
    try:
        tcp, joint = float(data["tcp_speed"]), float(data["joint_speed"])
        ranges = [float(x) for x in data["joint_ranges"]]
        on, rebound = data["on"], data["rebound"]
    except (KeyError, TypeError, ValueError):
        return
    if not (isinstance(on, bool) and isinstance(rebound, bool) and len(ranges) == 14
            and 0.0 < tcp <= m.max_tcp_speed and 0.0 < joint <= m.max_joint_speed
            and all(np.isfinite(ranges))):
        return
    lo, hi = m.lower, m.upper
    if any(not (lo[i] <= ranges[2 * i] < ranges[2 * i + 1] <= hi[i]) for i in range(ctl.dof)):
        return
    r.on, r.tcp_speed, r.joint_speed, r.joint_ranges, r.rebound = on, tcp, joint, ranges, rebound
