"""Loose objects of a scene file (``[[object]]`` tables beside ``[[plane]]`` and ``[[box]]``).

Pure data: reading the tables needs no physics engine. Each object is a rigid body that rests, falls,
slides and is carried by what holds it::

    [[object]]
    name = "cube"
    shape = "box"           # box: size = [x, y, z]; cylinder: [diameter, height]; sphere: [diameter]
    size = [40, 40, 40]     # mm
    mass = 0.1              # kg
    position = [300, -100, 20]   # mm, base frame: the centre of the shape
    rpy = [0, 0, 0]         # deg, optional (roll, pitch, yaw as the manual's poses, 1.5)
    friction = 1.0          # optional, Coulomb coefficient against whatever it touches
    color = "#d04020"       # optional, for the 3D view

A table with an error raises ``ValueError`` with one line naming the object and the key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ...tomlfile import check_keys

#: The shapes an object may have and how many sizes each takes (mm).
SHAPES = {"box": 3, "cylinder": 2, "sphere": 1}
#: The size keys of each shape, for messages.
SIZE_NAMES = {"box": "[x, y, z]", "cylinder": "[diameter, height]", "sphere": "[diameter]"}
DEFAULT_FRICTION = 1.0
DEFAULT_COLOR = (0.8, 0.3, 0.15, 1.0)
#: The keys of an ``[[object]]`` table.
KEYS = frozenset({"name", "shape", "size", "mass", "position", "rpy", "friction", "color"})


@dataclass(frozen=True)
class ObjectSpec:
    """One loose object as its scene table declares it (mm, kg, deg)."""

    name: str
    shape: str
    size: tuple[float, ...]
    mass: float
    position: tuple[float, float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    friction: float = DEFAULT_FRICTION
    color: tuple[float, float, float, float] = DEFAULT_COLOR

    @property
    def half_height(self) -> float:
        """Half its extent along its own z axis (mm): where it rests on a face."""
        return self.size[-1] / 2.0 if self.shape != "sphere" else self.size[0] / 2.0

    def to_dict(self) -> dict[str, Any]:
        """The table :func:`parse_object` reads back."""
        return {"name": self.name, "shape": self.shape, "size": list(self.size), "mass": self.mass,
                "position": list(self.position), "rpy": list(self.rpy), "friction": self.friction,
                "color": list(self.color)}


def _numbers(label: str, key: str, v: Any, n: int | None, what: str) -> tuple[float, ...]:
    if not isinstance(v, Sequence) or isinstance(v, str) or (n is not None and len(v) != n):
        raise ValueError(f"{label}: {key} must be {what}")
    out: list[float] = []
    for e in v:
        if isinstance(e, bool) or not isinstance(e, (int, float)) or not math.isfinite(float(e)):
            raise ValueError(f"{label}: {key} must be {what} (finite numbers)")
        out.append(float(e))
    return tuple(out)


def _color(label: str, v: Any) -> tuple[float, float, float, float]:
    if isinstance(v, str):
        h = v.lstrip("#")
        if len(h) != 6 or any(c not in "0123456789abcdefABCDEF" for c in h):
            raise ValueError(f"{label}: color must be '#rrggbb' or [r, g, b] from 0 to 1")
        return (int(h[0:2], 16) / 255, int(h[2:4], 16) / 255, int(h[4:6], 16) / 255, 1.0)
    c = _numbers(label, "color", v, None, "'#rrggbb' or [r, g, b] from 0 to 1")
    if len(c) not in (3, 4) or any(not 0.0 <= x <= 1.0 for x in c):
        raise ValueError(f"{label}: color must be '#rrggbb' or [r, g, b] from 0 to 1")
    return (c[0], c[1], c[2], c[3] if len(c) == 4 else 1.0)


def parse_object(i: int, t: Any) -> ObjectSpec:
    """One ``[[object]]`` table (the ``i``-th, from 0); ValueError naming the object and the key."""
    if not isinstance(t, Mapping):
        raise ValueError(f"object {i + 1}: a table of keys expected")
    label = f"object {t.get('name', i + 1)!s}"
    check_keys(t, sorted(KEYS), label)
    for need in ("shape", "size", "mass", "position"):
        if need not in t:
            raise ValueError(f"{label}: missing {need!r}")
    shape = t["shape"]
    if shape not in SHAPES:
        raise ValueError(f"{label}: shape must be one of {', '.join(SHAPES)}, not {shape!r}")
    size = _numbers(label, "size", t["size"], SHAPES[shape], f"{SIZE_NAMES[shape]} in mm")
    if min(size) <= 0:
        raise ValueError(f"{label}: size must be > 0")
    mass = t["mass"]
    if isinstance(mass, bool) or not isinstance(mass, (int, float)) or not math.isfinite(mass) or mass <= 0:
        raise ValueError(f"{label}: mass must be a number > 0 (kg)")
    pos = _numbers(label, "position", t["position"], 3, "[x, y, z] in mm")
    rpy = _numbers(label, "rpy", t.get("rpy", (0, 0, 0)), 3, "[roll, pitch, yaw] in degrees")
    friction = t.get("friction", DEFAULT_FRICTION)
    if (isinstance(friction, bool) or not isinstance(friction, (int, float)) or not math.isfinite(friction)
            or friction < 0):
        raise ValueError(f"{label}: friction must be a number >= 0")
    color = _color(label, t["color"]) if "color" in t else DEFAULT_COLOR
    name = str(t.get("name", f"object{i + 1}"))
    return ObjectSpec(name, shape, size, float(mass), (pos[0], pos[1], pos[2]), (rpy[0], rpy[1], rpy[2]),
                      float(friction), color)


def parse_objects(items: Any) -> tuple[ObjectSpec, ...]:
    """The ``[[object]]`` list of a scene; ValueError on a bad table or a name used twice."""
    if not isinstance(items, list):
        raise ValueError("object must be a list of tables ([[object]])")
    objs = tuple(parse_object(i, t) for i, t in enumerate(items))
    seen: set[str] = set()
    for o in objs:
        if o.name in seen:
            raise ValueError(f"object {o.name}: the name is used twice")
        seen.add(o.name)
    return objs
