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

Each entry runs right after the first control period ending at or after ``at`` (Emulator.at) and
acts exactly as the same admin request would. Every entry is checked when the emulator starts; a
bad one stops the start with one message naming it. The code that composes a server (``xarm-emu
serve``, :class:`~xarm_emu.server.thread.ServerThread`, :func:`~xarm_emu.testing.running_emulator`)
calls :func:`schedule_file`; the server itself never reads the file.
"""

from __future__ import annotations

import logging
import math
import tomllib
from pathlib import Path
from typing import Any

from .admin import SCHEDULABLE, AdminError, AdminTarget, prepare

log = logging.getLogger("xarm_emu.faults")


class FaultScheduleError(ValueError):
    """The fault schedule cannot be used; the message says which entry and why."""


def read_schedule(path: Path) -> list[dict[str, Any]]:
    """The ``[[fault]]`` entries of a schedule file, with ``at`` and ``do`` checked."""
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise FaultScheduleError(f"cannot read the fault schedule {path}: {exc.strerror or exc}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise FaultScheduleError(f"{path} is not valid TOML: {exc}") from None
    extra = sorted(set(data) - {"fault"})
    entries = data.get("fault")
    if extra or not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise FaultScheduleError(f"{path}: the schedule is a list of [[fault]] tables"
                                 + (f" (unknown key {extra[0]!r})" if extra else ""))
    for i, e in enumerate(entries, start=1):
        at = e.get("at")
        if isinstance(at, bool) or not isinstance(at, (int, float)) or not (math.isfinite(at) and at >= 0):
            raise FaultScheduleError(f"fault {i}: at is controller seconds >= 0, got {at!r}")
        do = e.get("do")
        if not isinstance(do, str) or do not in SCHEDULABLE:
            raise FaultScheduleError(f"fault {i}: do is one of {', '.join(sorted(SCHEDULABLE))}, "
                                     f"got {e.get('do')!r}")
    return entries


def schedule(server: AdminTarget, entries: list[dict[str, Any]]) -> int:
    """Check every entry against ``server`` and schedule it on its emulator; returns how many."""
    actions = []
    for i, e in enumerate(entries, start=1):
        request = {k: v for k, v in e.items() if k not in ("at", "do")}
        request["cmd"] = e["do"]
        try:
            actions.append((float(e["at"]), i, prepare(server, request)))
        except AdminError as exc:
            raise FaultScheduleError(f"fault {i} ({e['do']} at {e['at']} s): {exc}") from None
    for at, i, action in actions:
        server.emulator.at(at, _logged(server, i, action))
    return len(actions)


def _logged(server: AdminTarget, i: int, action: Any) -> Any:
    def run() -> None:
        try:
            message = action()
        except AdminError as exc:
            log.warning("fault %d at t = %.3f s refused: %s", i, server.emulator.time, exc)
            return
        log.info("fault %d at t = %.3f s: %s", i, server.emulator.time, message)

    return run


def schedule_file(server: AdminTarget, path: Path | None) -> int:
    """Read the schedule at ``path`` (none: nothing) and schedule it on ``server``; returns how many
    entries. Raises :class:`FaultScheduleError` naming a bad entry before anything is scheduled."""
    if path is None:
        return 0
    n = schedule(server, read_schedule(path))
    log.info("fault schedule %s: %d entries", path, n)
    return n
