"""Register handlers as plain functions, bound to register codes in one table.

Each module of this package holds the handlers of one group of registers, as the manual groups them
(section 2.1.3), and ends in a ``BINDINGS`` tuple of
:class:`~xarm_emu.controller.core.interface.Binding` rows: register code, handler
``handler(ctl, values) -> reply values | None``, and the modes (register 19) that route the code to
another handler. Components (IO, the tool RS-485 bus) declare their rows in the same form, with the
component class whose instance answers them. :data:`TABLE` is every row, checked at import: a code
bound twice is an error naming both handlers, and every handler is a plain function that
:func:`handler_of` can name.

Where one function serves several registers, the row binds the register code with
:func:`functools.partial` (``partial(move, register=21)``); no handler learns its register any
other way.
"""

from __future__ import annotations

import functools

from ...protocol.firmware import DEFAULT_VERSION, SUPPORTED_VERSIONS, FirmwareProfile, profile_for
from ...protocol.registers import registers_for
from ..applications.modes import create_state, extra_modes_of
from ..core.controller_protocol import Controller
from ..core.interface import Binding, Handler, binding_table, function_name
from ..devices import gripper, io
from . import (
    feedback,
    force_control,
    ft_sensor,
    kinematics,
    motion,
    reduced,
    relative_and_velocity,
    service,
    settings,
    state,
    trajectory,
)

#: Every register binding, the controller's and its components', by register code (checked at
#: import: :func:`~xarm_emu.controller.core.interface.binding_table`).
TABLE: dict[int, Binding] = binding_table((
    *state.BINDINGS,
    *motion.BINDINGS,
    *settings.BINDINGS,
    *kinematics.BINDINGS,
    *feedback.BINDINGS,
    *relative_and_velocity.BINDINGS,
    *reduced.BINDINGS,
    *trajectory.BINDINGS,
    *service.BINDINGS,
    *ft_sensor.BINDINGS,
    *force_control.BINDINGS,
    *io.BINDINGS,
    *gripper.BINDINGS,
))


def bind(ctl: Controller) -> tuple[dict[int, Handler], dict[int, dict[int, Handler]]]:
    """The dispatch table of ``ctl``: the handler of each controller row of :data:`TABLE` with the
    controller bound as its first argument, for the registers of ``ctl``'s firmware only; and the
    mode routes of those registers (register -> mode -> handler)."""
    create_state(ctl)  # the state behind these handlers exists from construction (checkpoints)
    service.extra_state(ctl)
    ft_sensor.ft_config(ctl)
    force_control.create_state(ctl)
    handlers: dict[int, Handler] = {}
    routes: dict[int, dict[int, Handler]] = {}
    for code, row in TABLE.items():
        if row.component is None and code in ctl.registers:
            handlers[code] = functools.partial(row.handler, ctl)
            if row.mode_route:
                routes[code] = {m: functools.partial(fn, ctl) for m, fn in row.mode_route.items()}
    return handlers, routes


def handler_of(code: int, firmware: FirmwareProfile) -> list[str] | None:
    """What answers register ``code`` on a box of ``firmware``, from :data:`TABLE`: the handler's
    module and function (and the component that must be plugged in), then ``in mode M: <function>``
    for each mode of that firmware that routes the code elsewhere; None when that firmware's
    register table lacks the code or nothing is bound to it."""
    row = TABLE.get(code)
    table = registers_for(firmware)
    if row is None or code not in table:
        return None
    owner = "" if row.component is None else f" (component {row.component.__qualname__})"
    modes = extra_modes_of(firmware, table)
    return [row.where + owner] + [f"in mode {m}: {function_name(fn)}"
                                  for m, fn in sorted(row.mode_route.items()) if m in modes]


def handled_by(code: int, versions: tuple[str, ...] = (DEFAULT_VERSION, SUPPORTED_VERSIONS[-1])) -> list[str]:
    """Lines naming what answers register ``code`` on each firmware of ``versions`` (the manual's
    ``DEFAULT_VERSION`` and the newest): ``handler on <version>: module.function`` and its mode routes."""
    out = []
    for version in versions:
        answer = handler_of(code, profile_for(version))
        if answer is None:
            out.append(f"handler on {version}: none (warning 13, unknown command)")
            continue
        out.append(f"handler on {version}: {answer[0]}")
        out += [f"  {line}" for line in answer[1:]]
    return out
