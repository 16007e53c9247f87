"""The admin channel's argument schemas: each argument of a command is declared by its name in the
request, its type (a check of the value as sent that returns the value to use) and its default.

A check refuses a bad value with :class:`AdminError`, whose one-line message goes back to the client
(``{"ok": false, "error": ...}``). Some types read the emulator they are for: a joint is 1..dof of its
arm, a gripper code one of its attached gripper's table. The commands themselves are in
:mod:`.admin`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..controller.devices.linear_track import TRACK_ERRORS
from ..controller.emulator import Emulator
from ..controller.scene import contact
from ..protocol import codes
from ..protocol.admin import MAX_SECONDS, checkpoint_name


class AdminError(ValueError):
    """A refused admin request (its message goes back to the client)."""


#: A type of argument: the value as sent (the default when the request leaves it out) and the
#: emulator it is for -> the checked value; AdminError when it is not one.
Check = Callable[[Any, Emulator], Any]


@dataclass(frozen=True)
class Arg:
    """One declared argument of an admin command."""

    name: str
    check: Check
    default: Any = None
    #: Another name the request may give it under (when it does not give ``name``).
    alias: str | None = None

    def value(self, request: dict[str, Any], emu: Emulator) -> Any:
        """This argument of ``request``, checked."""
        default = self.default if self.alias is None else request.get(self.alias, self.default)
        return self.check(request.get(self.name, default), emu)


def checked(args: tuple[Arg, ...], request: dict[str, Any], emu: Emulator) -> dict[str, Any]:
    """Every argument of ``args`` in ``request``, checked in their declared order, by name."""
    return {a.name: a.value(request, emu) for a in args}


_KIND = {"C": "control box error", "W": "warning", "S": "servo error", "G": "gripper error"}


def label(prefix: str) -> Check:
    """A code of the manual's table ``prefix`` (chapter 3), as its label ("C31") or number (31)."""

    def check(value: Any, emu: Emulator) -> codes.Code:
        if isinstance(value, bool) or not isinstance(value, (str, int)):
            raise AdminError(f"code must be a label like {prefix}11, got {value!r}")
        text = str(value).strip()
        if text.isdigit():
            text = prefix + text
        try:
            entry = codes.parse_label(text)
        except ValueError as exc:
            raise AdminError(str(exc)) from None
        if entry.prefix != prefix:
            raise AdminError(f"{entry.label} is not a {_KIND[prefix]} code ({prefix}<n>)")
        return entry

    return check


def gripper_code(value: Any, emu: Emulator) -> codes.Code:
    """A code of the attached gripper's table (codes.GRIPPER_TABLES), as "G14", 14 or "0x0E"; for a
    gripper without a table of named codes (the Inspire RH56 hand), an error byte 1..255 as its
    fingers report it."""
    if isinstance(value, bool) or not isinstance(value, (str, int)):
        raise AdminError(f"code must be a gripper code like G11 or 11, got {value!r}")
    text = str(value).strip().upper().removeprefix("G")
    try:
        number = int(text, 0)
    except ValueError:
        raise AdminError(f"not a gripper error code: {value!r} (examples: G11, 11, 0x0E)") from None
    gripper = emu.gripper_kind
    table = codes.GRIPPER_TABLES.get(gripper)
    if table is None:  # the hand's error bytes: no code table, any byte but 0 (none)
        if not 1 <= number <= 0xFF:
            raise AdminError(f"an error byte of the {gripper} hand is 1..255, got {number}")
        return codes.Code(number, "G", "error byte", "Clear the hand's errors (its register 1004).")
    entry = table.get(number)
    if entry is None:
        raise AdminError(f"{number} is not an error code of the {gripper} gripper; known: "
                         + ", ".join(str(c) for c in sorted(table)))
    return entry


def integer(name: str) -> Check:
    """A whole number (an integer or its decimal text)."""
    return lambda value, emu: as_int(value, name)


def as_int(value: Any, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        if isinstance(value, str) and value.strip().lstrip("-").isdigit():
            return int(value)
        raise AdminError(f"{name} must be an integer, got {value!r}")
    return value


def joint(value: Any, emu: Emulator) -> int:
    """A joint number of the emulator's arm, 1..dof."""
    j = as_int(value, "joint")
    if not 1 <= j <= emu.model.dof:
        raise AdminError(f"joint {j} out of range 1..{emu.model.dof}")
    return j


def track_code(value: Any, emu: Emulator) -> int:
    """An error code of the attached linear track's drive (TRACK_ERRORS)."""
    code = as_int(value, "code")
    if emu.linear_track is None:
        raise AdminError("no linear track is attached (serve --linear-track)")
    if code not in TRACK_ERRORS:
        raise AdminError(f"linear track error {code}: one of {', '.join(map(str, TRACK_ERRORS))}")
    return code


def ft_code(value: Any, emu: Emulator) -> int:
    """An error code of the attached F/T sensor, 0..255 (0 clears; 27 is the sensor's no-error)."""
    if not emu.has_ft_sensor:
        raise AdminError("no F/T sensor is attached: start the emulator with --ft-sensor")
    code = as_int(value, "code")
    if not 0 <= code <= 255 or code == 27:
        raise AdminError(f"F/T sensor error code {code} out of range 0..255 (27 means no error)")
    return code


def as_float(value: Any, name: str) -> float:
    if isinstance(value, bool):
        raise AdminError(f"{name} must be a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise AdminError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise AdminError(f"{name} must be finite, got {value!r}")
    return x


def number(name: str) -> Check:
    """A finite number."""
    return lambda value, emu: as_float(value, name)


def vector(n: int, name: str) -> Check:
    """A list of ``n`` finite numbers."""

    def check(value: Any, emu: Emulator) -> list[float]:
        if not isinstance(value, (list, tuple)) or len(value) != n:
            raise AdminError(f"{name} must be a list of {n} numbers, got {value!r}")
        return [as_float(x, name) for x in value]

    return check


def parse_duration(text: str) -> float:
    """'2s', '50ms', '1.5' (seconds), '250us' -> seconds."""
    t = text.strip().lower()
    for suffix, scale in (("ms", 1e-3), ("us", 1e-6), ("s", 1.0), ("", 1.0)):
        if suffix and not t.endswith(suffix):
            continue
        digits = t[: len(t) - len(suffix)] if suffix else t
        try:
            value = float(digits) * scale
        except ValueError:
            break
        if not math.isfinite(value) or value < 0:
            break
        return value
    raise AdminError(f"not a duration: {text!r} (examples: 2s, 50ms, 0.5)")


def seconds(value: Any, emu: Emulator | None = None) -> float:
    """A wall-clock or controller time, 0..MAX_SECONDS, as a number or a duration ('50ms')."""
    if isinstance(value, str):
        value = parse_duration(value)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise AdminError(f"seconds must be a number, got {value!r}")
    if not 0.0 <= value <= MAX_SECONDS:
        raise AdminError(f"seconds {value} out of range 0..{MAX_SECONDS:g}")
    return float(value)


def hold(value: Any, emu: Emulator) -> float | None:
    """How long an external wrench is played: a time > 0, or none (held until replaced)."""
    duration = None if value is None else seconds(value)
    if duration == 0:
        raise AdminError("for must be a time > 0 s (leave it out to hold the wrench)")
    return duration


def flag(name: str) -> Check:
    """true or false."""

    def check(value: Any, emu: Emulator) -> bool:
        if not isinstance(value, bool):
            raise AdminError(f"{name} must be true or false, got {value!r}")
        return value

    return check


def choice(options: tuple[str, ...], refusal: str) -> Check:
    """One of ``options``; else ``refusal`` with ``{value}`` (as sent) and ``{known}`` filled in."""

    def check(value: Any, emu: Emulator) -> str:
        if value not in options:
            raise AdminError(refusal.format(value=repr(value), known=", ".join(options)))
        return str(value)

    return check


def checkpoint(value: Any, emu: Emulator) -> str:
    """A checkpoint name (protocol.admin.checkpoint_name)."""
    try:
        return checkpoint_name(value)
    except ValueError as exc:
        raise AdminError(str(exc)) from None


def scene(value: Any, emu: Emulator) -> contact.Scene:
    """A contact scene as the tables of a scene file (controller/contact.py)."""
    try:
        return contact.parse_scene(value)
    except ValueError as exc:
        raise AdminError(f"scene: {exc}") from None


def scene_object(value: Any, emu: Emulator) -> str:
    """The name of an object of the emulator's physics world."""
    names = [o["name"] for o in emu.scene_objects()]
    if value not in names:
        raise AdminError(f"no object {value!r} in the scene (objects: {', '.join(names)})")
    return str(value)


def place(key: str) -> Check:
    """Three numbers (mm or deg) of ``scene-place``."""

    def check(value: Any, emu: Emulator) -> tuple[float, float, float]:
        try:
            return contact.vec3("scene-place", key, value)
        except ValueError as exc:
            raise AdminError(str(exc)) from None

    return check


def scene_added(value: Any, emu: Emulator) -> contact.Scene:
    """The emulator's scene with the tables ``value`` (``{"object": [...], "conveyor": [...], ...}``,
    as in a scene file) added."""
    if not isinstance(value, dict) or not value:
        raise AdminError("tables: a table of lists, as a scene file's, e.g. {\"object\": [{...}]}")
    tables = contact.scene_of(emu.controller).to_dict()
    for kind, items in value.items():
        if not isinstance(items, list):
            raise AdminError(f"tables: {kind} must be a list of tables")
        tables.setdefault(str(kind), [])
        tables[str(kind)] = [*tables[str(kind)], *items]
    return scene(tables, emu)


def scene_without(value: Any, emu: Emulator) -> contact.Scene:
    """The emulator's scene without the element named ``value`` (a plane, box, object, conveyor,
    sensor or feeder)."""
    tables = contact.scene_of(emu.controller).to_dict()
    names = [str(t.get("name")) for items in tables.values() for t in items]
    if value not in names:
        raise AdminError(f"no element {value!r} in the scene (elements: {', '.join(names)})")
    return scene({k: [t for t in items if t.get("name") != value] for k, items in tables.items()}, emu)
