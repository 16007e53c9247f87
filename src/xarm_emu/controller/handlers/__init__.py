"""Register handlers as plain functions, bound to register codes in one place.

Each module of this package holds the handlers of one group of registers, as the manual groups them
(section 2.1.3), and ends in a ``HANDLERS`` mapping from register code to a function
``handler(ctl, values) -> reply values | None``. :data:`TABLES` lists those mappings; :func:`bind`
turns them into the controller's dispatch table. Components (IO, grippers, sensors) add theirs
through :meth:`~xarm_emu.controller.core.interface.Component.handlers`.

Where one function serves several registers, the table binds the register code with
:func:`functools.partial` (``partial(move, register=21)``); no handler learns its register any
other way.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping

from ..applications.modes import create_state
from ..core.controller_protocol import Controller, CtlHandler
from ..core.interface import Handler
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

__all__ = ["TABLES", "CtlHandler", "bind"]

#: Every handler table of this package, in the order they bind (a later table never rebinds a code:
#: :func:`bind` refuses duplicates).
TABLES: tuple[Mapping[int, CtlHandler], ...] = (
    state.HANDLERS,
    motion.HANDLERS,
    settings.HANDLERS,
    kinematics.HANDLERS,
    feedback.HANDLERS,
    relative_and_velocity.HANDLERS,
    reduced.HANDLERS,
    trajectory.HANDLERS,
    service.HANDLERS,
    ft_sensor.HANDLERS,
    force_control.HANDLERS,
)


def bind(ctl: Controller,
         tables: tuple[Mapping[int, CtlHandler], ...] | None = None) -> dict[int, Handler]:
    """The dispatch table of ``ctl``: each handler of ``tables`` (default :data:`TABLES`) with the
    controller bound as its first argument, for the registers of ``ctl``'s firmware only."""
    create_state(ctl)  # the state behind these handlers exists from construction (checkpoints)
    service.extra_state(ctl)
    ft_sensor.ft_config(ctl)
    force_control.create_state(ctl)
    out: dict[int, Handler] = {}
    for table in TABLES if tables is None else tables:
        for code, fn in table.items():
            if code in out:
                raise ValueError(f"register {code} is bound twice")
            if code in ctl.registers:
                out[code] = functools.partial(fn, ctl)
    return out
