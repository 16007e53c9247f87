"""The control box's settable parameters and their ranges.

Ranges are Table 1.2 of the manual (section 1.3); the configuration that
register 40 saves is :class:`Settings` (everything here but the transient
motion values).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

# Table 1.2 (manual section 1.3): ranges of the motion parameters.
TCP_SPEED_MAX = 1000.0  # mm/s
TCP_ACC_MAX = 50000.0  # mm/s^2
TCP_JERK_MAX = 10000.0  # mm/s^3
JOINT_SPEED_MAX = math.pi  # 180 deg/s
JOINT_ACC_MAX = math.radians(1145.0)  # rad/s^2
JOINT_JERK_MAX = math.radians(28647.0)  # rad/s^3
#: Section 1.3 note 2: for orientation-only moves 0..1000 maps to 0..180 deg/s.
ROT_SPEED_PER_TCP_SPEED = math.pi / TCP_SPEED_MAX

COLLISION_SENSITIVITY_RANGE = (0, 5)  # section 1.5
TEACH_SENSITIVITY_RANGE = (1, 5)


def in_range(value: float, hi: float, lo: float = 0.0) -> bool:
    """True when value is finite and within [lo, hi]."""
    return math.isfinite(value) and lo <= value <= hi


@dataclass
class Settings:
    """The saved configuration (register 40 saves it, 39 restores defaults)."""

    tcp_offset: list[float] = field(default_factory=lambda: [0.0] * 6)
    tcp_load: list[float] = field(default_factory=lambda: [0.0] * 4)  # kg, cx, cy, cz mm (flange frame)
    gravity_direction: list[float] = field(default_factory=lambda: [0.0, 0.0, -1.0])
    collision_sensitivity: int = 3
    teach_sensitivity: int = 3
    tcp_jerk: float = TCP_JERK_MAX
    tcp_maxacc: float = TCP_ACC_MAX
    joint_jerk: float = JOINT_JERK_MAX
    joint_maxacc: float = JOINT_ACC_MAX
    world_offset: list[float] = field(default_factory=lambda: [0.0] * 6)
    #: Safety boundary (register 52): x max, x min, y max, y min, z max, z min (mm).
    boundary: list[int] = field(default_factory=lambda: [1000, -1000, 1000, -1000, 1000, -1000])
    boundary_on: bool = False
    self_collision_on: bool = False
    collision_tool: list[float] = field(default_factory=lambda: [0.0] * 7)  # type, then up to 6 params
    report_current: bool = False  # registers 24 / 70: report motor current instead of torque
    io: dict[str, Any] = field(default_factory=dict)  # owned by the IO component

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Settings:
        """Build settings from saved data; unknown keys are ignored, missing ones default."""
        base = cls()
        names = {f.name for f in fields(cls)}
        for key, value in data.items():
            if key in names:
                setattr(base, key, value)
        return base
