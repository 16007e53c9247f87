"""A fault schedule (``xarm-emu serve --faults FILE``): faults and inputs at given controller times,
so a CI run can meet an emergency stop at t = 3 s without a harness driving the admin channel.

A TOML file of ``[[fault]]`` tables; ``at`` is controller time in seconds since start (the clock
the motion runs on, so a schedule lands on the same control period at any ``--speed`` and in
lockstep), ``do`` one of the admin channel's commands (server/admin.py) and the other keys its
arguments::

    [[fault]]
    at = 2.0
    do = "collision"
    joint = 2
    torque = 40.0

    [[fault]]
    at = 3.5
    do = "set-input"
    kind = "cgpio"
    index = 3
    value = 1

    [[fault]]
    at = 5.0
    do = "report-pause"
    seconds = "2s"

    [[fault]]              # an external wrench on the TCP (serve --ft-sensor): 10 N along tool z
    at = 6.0
    do = "set-input"
    kind = "ft"
    wrench = [0, 0, 10, 0, 0, 0]
    frame = "tool"
    ramp = 0.5
    for = 2.0

An entry may count ``at`` from another moment with ``after``: ``"start"`` (the default, the
emulator's start), ``"connect"`` (the first client connection to the command port) or
``"motion"`` (the first motion: the arm's state becomes 1, in motion, manual 2.1.3 register 13).
So a schedule written for a program lands on the program's moves at any ``--speed``::

    [[fault]]
    after = "motion"
    at = 2.0
    do = "estop"

Each entry runs right after the first control period ending at or after ``at`` (Emulator.at) and
acts exactly as the same admin request would; with ``serve --trace`` it is written to the trace as
it fires (an ``outside`` line, server/trace.py), so ``xarm-emu replay`` does it again. Keys other
than ``at``, ``after``, ``do`` and the admin command's own arguments are refused. Every entry is
checked when the emulator starts; a bad one stops the start with one message naming the file and
the entry (the TOML files' one format, :mod:`xarm_emu.tomlfile`). The code that composes a server
(``xarm-emu serve``, :class:`~xarm_emu.server.thread.ServerThread`,
:func:`~xarm_emu.testing.running_emulator`) calls :func:`schedule_file`; the server itself never
reads the file.
"""

from __future__ import annotations

import functools
import logging
import math
from pathlib import Path
from typing import Any

from ..tomlfile import check_keys, load_toml
from .admin import SCHEDULABLE, AdminError, AdminTarget, arguments, prepare

log = logging.getLogger("xarm_emu.faults")


#: The moments ``at`` may count from.
AFTER = ("start", "connect", "motion")
#: How often (controller seconds) a schedule waiting for a connection or a motion looks again.
_WATCH = 0.01


class FaultScheduleError(ValueError):
    """The fault schedule cannot be used; the message says which entry and why."""


def read_schedule(path: Path) -> list[dict[str, Any]]:
    """The ``[[fault]]`` entries of a schedule file, with ``at`` and ``do`` checked; a refusal names
    the file (the TOML files' one format, xarm_emu.tomlfile)."""
    return load_toml(path, "fault schedule", parse_schedule, FaultScheduleError)


def parse_schedule(data: dict[str, Any]) -> list[dict[str, Any]]:
    """The ``[[fault]]`` entries of a schedule already read from TOML, with ``at`` and ``do`` checked."""
    check_keys(data, ("fault",), error=FaultScheduleError)
    entries = data.get("fault")
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise FaultScheduleError("the schedule is a list of [[fault]] tables")
    for i, e in enumerate(entries, start=1):
        after = e.get("after", "start")
        if after not in AFTER:
            raise FaultScheduleError(f"fault {i}: after is one of {', '.join(AFTER)}, got {after!r}")
        at = e.get("at")
        if isinstance(at, bool) or not isinstance(at, (int, float)) or not (math.isfinite(at) and at >= 0):
            raise FaultScheduleError(f"fault {i}: at is controller seconds >= 0, got {at!r}")
        do = e.get("do")
        if not isinstance(do, str) or do not in SCHEDULABLE:
            raise FaultScheduleError(f"fault {i}: do is one of {', '.join(sorted(SCHEDULABLE))}, "
                                     f"got {e.get('do')!r}")
        check_keys(e, ("at", "after", "do", *ARGUMENTS.get(do, ())), f"fault {i} ({do})", FaultScheduleError)
    return entries


def schedule(server: AdminTarget, entries: list[dict[str, Any]]) -> int:
    """Check every entry against ``server`` and schedule it on its emulator; returns how many."""
    server.emulator.outside["server"] = server  # what the scheduled actions act on, by name
    actions = []
    for i, e in enumerate(entries, start=1):
        request = {k: v for k, v in e.items() if k not in ("at", "do", "after")}
        request["cmd"] = e["do"]
        try:
            action = prepare(server, request, source="schedule")
        except AdminError as exc:
            raise FaultScheduleError(f"fault {i} ({e['do']} at {e['at']} s): {exc}") from None
        actions.append((float(e["at"]), str(e.get("after", "start")), i, action))
    for k, (at, after, i, action) in enumerate(actions):
        if entries[k]["do"] == "drop-clients":  # transports: the event loop's, whoever steps the arm
            in_loop = getattr(server, "in_loop", None)
            if in_loop is not None:
                action = functools.partial(in_loop, action)
        if after == "start":
            server.emulator.at(at, _logged(server, i, action))
        else:
            _watch(server, after, at, _logged(server, i, action))
    return len(actions)


#: The arguments each schedulable admin command takes (its declared arguments in the admin table,
#: server/admin.py), beside ``at``, ``after`` and ``do``.
ARGUMENTS: dict[str, tuple[str, ...]] = {cmd: arguments(cmd) for cmd in sorted(SCHEDULABLE)}


def _started(server: AdminTarget, after: str) -> bool:
    """Whether the moment ``after`` names has come."""
    if after == "connect":
        return bool(getattr(server, "command_clients", ()))
    return server.emulator.controller.state == 1


def _watch(server: AdminTarget, after: str, at: float, action: Any) -> None:
    """Schedule ``action`` ``at`` seconds after the moment ``after`` names, looking for it every
    :data:`_WATCH` seconds of controller time."""
    emu = server.emulator
    emu.at(emu.time, functools.partial(_look, server, after, at, action))


def _look(server: AdminTarget, after: str, at: float, action: Any) -> None:
    """One look of :func:`_watch`: the moment has come (schedule ``action``) or look again later.
    Scheduled actions are partials of module-level functions, so a checkpoint can write them."""
    emu = server.emulator
    if _started(server, after):
        log.info("fault schedule: %s at t = %.3f s; entry due %.3f s later", after, emu.time, at)
        emu.at(emu.time + at, action)
    else:
        emu.at(emu.time + _WATCH, functools.partial(_look, server, after, at, action))


def _logged(server: AdminTarget, i: int, action: Any) -> Any:
    """``action`` as entry ``i`` of the schedule: what it did, or why it was refused, logged."""
    return functools.partial(_run_logged, server, i, action)


def _run_logged(server: AdminTarget, i: int, action: Any) -> None:
    try:
        message = action()
    except AdminError as exc:
        log.warning("fault %d at t = %.3f s refused: %s", i, server.emulator.time, exc)
        return
    log.info("fault %d at t = %.3f s: %s", i, server.emulator.time, message)


def schedule_file(server: AdminTarget, path: Path | None) -> int:
    """Read the schedule at ``path`` (none: nothing) and schedule it on ``server``; returns how many
    entries. Raises :class:`FaultScheduleError` naming a bad entry before anything is scheduled."""
    if path is None:
        return 0
    entries = read_schedule(path)  # its refusals name the file already
    try:
        n = schedule(server, entries)
    except FaultScheduleError as exc:  # an entry this server refuses: named in the same format
        raise FaultScheduleError(f"fault schedule {path}: {exc}") from None
    log.info("fault schedule %s: %d entries", path, n)
    return n
