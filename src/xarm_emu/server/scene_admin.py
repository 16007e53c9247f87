"""Admin commands on the objects of the physics world (no real control box has these):
``scene-objects`` (every object's pose and whether the hand holds it, as JSON), ``scene-place``
(``name``, ``position`` mm, optional ``rpy`` deg) and ``scene-reset`` (every object back where the
scene file puts it). Each request is checked before anything changes; ValueError refuses it."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from ..controller.emulator import Emulator
from ..controller.scene import contact

COMMANDS = ("scene-objects", "scene-place", "scene-reset")


def _vector(request: dict[str, Any], key: str, default: Any = None) -> tuple[float, float, float]:
    return contact.vec3("scene-place", key, request.get(key, default))


def prepare(emu: Emulator, cmd: str, request: dict[str, Any]) -> Callable[[], str]:
    """The checked action of one scene command; ValueError for a bad request."""
    if emu.physics is None:
        raise ValueError("the scene has no objects (serve --scene with [[object]] tables)")
    if cmd == "scene-objects":
        return lambda: json.dumps({"time": emu.time, "objects": emu.scene_objects()})
    if cmd == "scene-reset":
        def reset() -> str:
            emu.reset_objects()
            return "every object back where the scene puts it"

        return reset
    name = request.get("name")
    names = [o["name"] for o in emu.scene_objects()]
    if name not in names:
        raise ValueError(f"no object {name!r} in the scene (objects: {', '.join(names)})")
    position = _vector(request, "position")
    rpy = _vector(request, "rpy", [0.0, 0.0, 0.0])

    def place() -> str:
        emu.place_object(str(name), position, rpy)
        return f"{name} at ({position[0]:g}, {position[1]:g}, {position[2]:g}) mm"

    return place
