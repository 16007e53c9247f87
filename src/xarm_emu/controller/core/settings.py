"""The control box's settable parameters (the configuration register 40 saves).

The motion parameter ranges of Table 1.2 (manual section 1.3) live in the
robot model (:class:`~xarm_emu.model.robots.RobotModel`); jerk and maximum
acceleration settings start at those maxima (:meth:`Settings.for_model`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from ...model.robots import RobotModel
from .interface import PARAMETER_LIMIT

log = logging.getLogger(__name__)

COLLISION_SENSITIVITY_RANGE = (0, 5)  # section 1.5
TEACH_SENSITIVITY_RANGE = (1, 5)


#: The settings of registers 31-34 and the model maximum each starts at and may not exceed
#: (manual 1.3 Table 1.2).
MOTION_LIMITS = {"tcp_jerk": "max_tcp_jerk", "tcp_maxacc": "max_tcp_acc",
                 "joint_jerk": "max_joint_jerk", "joint_maxacc": "max_joint_acc"}


def in_range(value: float, hi: float, lo: float = 0.0) -> bool:
    """True when value is finite and within [lo, hi]."""
    return math.isfinite(value) and lo <= value <= hi


@dataclass(slots=True)
class Settings:
    """The saved configuration (register 40 saves it, 39 restores defaults)."""

    tcp_offset: list[float] = field(default_factory=lambda: [0.0] * 6)
    tcp_load: list[float] = field(default_factory=lambda: [0.0] * 4)  # kg, cx, cy, cz mm (flange frame)
    gravity_direction: list[float] = field(default_factory=lambda: [0.0, 0.0, -1.0])
    collision_sensitivity: int = 3
    teach_sensitivity: int = 3
    tcp_jerk: float = 0.0  # mm/s^3; for_model() sets the model's maxima
    tcp_maxacc: float = 0.0  # mm/s^2
    joint_jerk: float = 0.0  # rad/s^3
    joint_maxacc: float = 0.0  # rad/s^2
    world_offset: list[float] = field(default_factory=lambda: [0.0] * 6)
    #: Safety boundary (register 52): x max, x min, y max, y min, z max, z min (mm).
    boundary: list[int] = field(default_factory=lambda: [1000, -1000, 1000, -1000, 1000, -1000])
    boundary_on: bool = False
    self_collision_on: bool = False
    collision_tool: list[float] = field(default_factory=lambda: [0.0] * 7)  # type, then up to 6 params
    report_current: bool = False  # registers 24 / 70: report motor current instead of torque

    @classmethod
    def for_model(cls, model: RobotModel) -> Settings:
        """Defaults of a freshly configured control box for ``model``."""
        return cls(**{name: getattr(model, limit) for name, limit in MOTION_LIMITS.items()})

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], model: RobotModel) -> Settings:
        """Build settings from saved data; unknown keys are ignored, missing ones default.

        A saved value of the wrong shape (type, length, a non-finite number, a payload the model does
        not carry) keeps its default and is logged: a file written by an older or a hand-changed
        emulator must not put values in the controller that its registers would have refused.
        """
        base = cls.for_model(model)
        names = {f.name for f in fields(cls)}
        for key, value in data.items():
            if key not in names:
                continue
            default = getattr(base, key)
            if _same_shape(default, value) and _plausible(key, value, model):
                setattr(base, key, _as_type_of(default, value))
            else:
                log.warning("saved setting %s=%r is not valid here; keeping the default", key, value)
        return base


def _same_shape(default: Any, value: Any) -> bool:
    """True when ``value`` has the type (and for lists the length) of ``default``, numbers finite."""
    if isinstance(default, bool):
        return isinstance(value, bool)
    if isinstance(default, (int, float)):
        return (isinstance(value, (int, float)) and not isinstance(value, bool)
                and math.isfinite(value) and abs(value) <= PARAMETER_LIMIT
                and (isinstance(default, float) or value == int(value)))
    if isinstance(default, list):
        return (isinstance(value, list) and len(value) == len(default)
                and all(_same_shape(d, v) for d, v in zip(default, value, strict=True)))
    if isinstance(default, dict):
        return isinstance(value, dict)
    return False


def _as_type_of(default: Any, value: Any) -> Any:
    """``value`` converted to the types of ``default`` (a saved 3.0 for an int field is 3)."""
    if isinstance(default, bool) or not isinstance(default, (int, float, list)):
        return value
    if isinstance(default, list):
        return [_as_type_of(d, v) for d, v in zip(default, value, strict=True)]
    return type(default)(value)


def gravity_ok(direction: Any) -> bool:
    """Register 51: a finite, non-zero gravity direction."""
    v = [float(x) for x in direction]
    return len(v) == 3 and all(math.isfinite(x) for x in v) and any(x != 0.0 for x in v)


def boundary_ok(boundary: Any) -> bool:
    """Register 52: x max, x min, y max, y min, z max, z min (mm), no maximum below its minimum."""
    b = list(boundary)
    return len(b) == 6 and b[0] >= b[1] and b[2] >= b[3] and b[4] >= b[5]


def _plausible(key: str, value: Any, model: RobotModel) -> bool:
    """The ranges the setting registers enforce that a shape check cannot see."""
    if key == "tcp_load":
        return (0.0 <= value[0] <= model.rated_payload
                and all(abs(c) <= model.payload_com_limit for c in value[1:]))
    if key in MOTION_LIMITS:
        return 0.0 < value <= getattr(model, MOTION_LIMITS[key])
    if key == "collision_sensitivity":
        return in_range(value, COLLISION_SENSITIVITY_RANGE[1], COLLISION_SENSITIVITY_RANGE[0])
    if key == "teach_sensitivity":
        return in_range(value, TEACH_SENSITIVITY_RANGE[1], TEACH_SENSITIVITY_RANGE[0])
    if key == "gravity_direction":
        return gravity_ok(value)
    if key == "boundary":
        return boundary_ok(value)
    return True
