"""The controller's fault group (manual chapter 3): error code, warning code and servo errors."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(slots=True)
class Faults:
    """Error (section 3.2.1, 0 none), warning (3.2.2) and per-joint servo error codes (3.1)."""

    error: int = 0
    warning: int = 0
    servo_errors: list[int] = field(default_factory=list)

    @classmethod
    def none(cls, dof: int) -> Faults:
        """No fault on an arm of ``dof`` joints."""
        return cls(servo_errors=[0] * dof)
