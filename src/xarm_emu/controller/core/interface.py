"""Shared pieces of the controller: the control period, command outcomes and
the interface controller components (IO, gripper, ...) plug in through.

Every register handler, the controller's and a component's, is bound by one
row of the binding table (:class:`Binding`). A handler gets the request values
decoded by the register table and returns the reply values (or ``None`` for an
empty reply). It signals a refusal by raising :class:`CommandWarning` (the
manual's warning codes, section 3.2.2) or :class:`CommandError` (a control box
error code, section 3.2.1).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

#: Control period in seconds: the controller advances in steps of 4 ms (250 Hz,
#: the real control box's planning rate).
PERIOD = 0.004

#: Largest magnitude a float parameter may have on the wire. Every fp32 the manual defines is a
#: length in mm, an angle, a speed, an acceleration, a time or an analog value, all far below this;
#: a larger (or NaN, or infinite) value is parameter abnormal, warning 12, whatever the register. The
#: bound also keeps everything computed from parameters inside the fp32 range of the replies.
PARAMETER_LIMIT = 1.0e9

# Control box error codes the controller raises (manual section 3.2.1; names and handling text in
# protocol/codes.py).
C_ESTOP = 1
C_SERVO_BASE = 10  # C11..C17: servo error on joint 1..7
C_KINEMATIC = 21
C_SELF_COLLISION = 22
C_JOINT_LIMIT = 23
C_SPEED = 24
C_PLANNING = 25
C_END_MODULE = 28
C_OTHER = 29
C_COLLISION = 31
C_CIRCLE = 32
C_BOUNDARY = 35
C_DELAYED_IO = 36

# Warning codes, manual section 3.2.2.
WARN_BUFFER_OVERFLOW = 11
WARN_PARAMETER = 12
WARN_UNKNOWN_COMMAND = 13
WARN_NO_SOLUTION = 14

Values = Mapping[str, Any]
Handler = Callable[[Values], "dict[str, Any] | None"]


@dataclass(frozen=True, slots=True)
class Binding:
    """One row of the register binding table: register ``code`` (manual section 2.1.3) is answered
    by ``handler(owner, values)``, a plain function (or a :func:`functools.partial` of one) that
    returns the reply values or ``None`` for an empty reply.

    ``owner`` is the controller when ``component`` is ``None``; otherwise the plugged-in component of
    that class (IO, the tool RS-485 bus), and the code answers only while such a component is
    plugged in. ``mode_route`` names the modes (register 19) in which another handler, taking the
    controller, answers the code instead (a joint or linear move in online planning, modes 6/7)."""

    code: int
    handler: Callable[..., Any]
    component: type | None = None
    mode_route: Mapping[int, Callable[..., Any]] = field(default_factory=dict)

    @property
    def where(self) -> str:
        """The handler's module and function name (:func:`function_name`)."""
        return function_name(self.handler)


def function_name(fn: Callable[..., Any]) -> str:
    """``module.function`` of a handler, with a partial's bound arguments (``move_line(register=21)``);
    a lambda or a function defined inside another has no such name: :class:`ValueError`."""
    args = ""
    if isinstance(fn, functools.partial):
        args = "(" + ", ".join(f"{k}={v!r}" for k, v in fn.keywords.items()) + ")"
        fn = fn.func
    name = f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"
    if "<lambda>" in name or "<locals>" in name or "?" in name:
        raise ValueError(f"handler {name} is not a plain function: it cannot be named")
    return name + args


def binding_table(rows: Iterable[Binding]) -> dict[int, Binding]:
    """The rows by register code, checked: every handler (and mode route) is a plain function, and a
    code bound twice is a :class:`ValueError` naming both handlers."""
    out: dict[int, Binding] = {}
    for row in rows:
        for fn in (row.handler, *row.mode_route.values()):
            function_name(fn)
        if (first := out.get(row.code)) is not None:
            raise ValueError(f"register {row.code} is bound twice: {first.where} and {row.where}")
        out[row.code] = row
    return out


def bind_component(component: object, rows: Iterable[Binding]) -> dict[int, Handler]:
    """The handlers of ``rows`` that ``component`` answers (its class's rows), bound to it."""
    return {r.code: functools.partial(r.handler, component) for r in rows
            if r.component is not None and isinstance(component, r.component)}


class CommandWarning(Exception):
    """Refuse a command and raise the given warning (0x20 in the reply)."""

    def __init__(self, code: int = WARN_PARAMETER, message: str = "") -> None:
        super().__init__(message or f"warning {code}")
        self.code = code


class ParameterError(CommandWarning):
    """Parameter abnormal: warning 12."""

    def __init__(self, message: str = "") -> None:
        super().__init__(WARN_PARAMETER, message)


def _no_tool_error() -> int:
    return 0


@dataclass
class Hooks:
    """What the controller calls outside itself: saving (register 40) and deleting (register 39) the
    configuration, and the end tool's error code (register 106, the gripper's)."""

    on_save: Callable[[dict[str, Any]], None] | None = None
    on_clean_conf: Callable[[], None] | None = None
    tool_error: Callable[[], int] = _no_tool_error


class CommandFailed(Exception):
    """The command cannot be carried out now (reply bit 0x08, the SDK's code 10); nothing changes."""


class NotReady(Exception):
    """A motion command while the arm cannot move: nothing queued, no warning, the reply shows 0x10."""

    def __init__(self) -> None:
        super().__init__("arm not ready for motion")


class CommandError(Exception):
    """Raise a control box error (0x40 in the reply, state 4)."""

    def __init__(self, code: int, message: str = "") -> None:
        super().__init__(message or f"error C{code}")
        self.code = code


class ControllerView(Protocol):
    """What a component may read of the controller while it steps."""

    @property
    def time(self) -> float: ...  # controller time, s

    @property
    def state(self) -> int: ...  # motion state 1..5 (register 13)

    @property
    def mode(self) -> int: ...

    @property
    def error_code(self) -> int: ...

    @property
    def warning_code(self) -> int: ...

    @property
    def tcp_position(self) -> tuple[float, float, float]: ...  # mm, base frame (user offset applied)

    @property
    def is_moving(self) -> bool: ...

    def raise_error(self, code: int) -> None: ...  # a component raises a control box error


#: What :func:`idle_until` answers for a component that cannot tell: never idle.
NOT_IDLE = -math.inf


def idle_until(component: object, ctl: ControllerView) -> float:
    """Controller time up to which ``component`` is idle: with the controller at rest, stepping it in
    any control period that ends before this time would leave it exactly as its last step did (its
    own record of the time aside, which the next real step sets again). ``math.inf``: idle until
    something changes. Components opt in with a method ``idle_until(ctl) -> float``; one without it
    is never idle (:data:`NOT_IDLE`), so the stepped clock steps every period while it is plugged in
    (the emulator's jump over idle periods, controller/emulator.py)."""
    fn = getattr(component, "idle_until", None)
    return NOT_IDLE if fn is None else float(fn(ctl))
