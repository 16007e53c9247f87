"""The contact scene: planes and boxes the TCP can press into, each a spring-damper (stiffness
N/mm, damping N s/mm) with optional Coulomb friction, so that force control and the F/T sensor
(:mod:`..devices.ft_sensor`) feel a table or a part.

Shapes are fixed in the robot's base frame (mm). A plane is a point and an outward normal (the solid
is on the other side); a box is its two opposite corners, axis-aligned. While the TCP point is inside
a shape the shape pushes it out along the normal of the nearest face with ``k * depth + c * rate``
(never pulling: the normal force is at least zero), and friction opposes the sliding velocity with
at most ``mu`` times that force. The scene is declared in a TOML file (``serve --scene``)::

    [[plane]]
    name = "table"
    point = [0, 0, 100]    # mm
    normal = [0, 0, 1]
    stiffness = 10.0       # N/mm
    damping = 0.05         # N s/mm
    friction = 0.0

    [[box]]
    name = "block"
    min = [300, -50, 0]
    max = [400, 50, 120]
    stiffness = 5.0

or through the admin channel as the same tables (:func:`parse_scene`). A file with errors raises
``ValueError`` with one line naming the shape and the key.

``[[object]]`` tables add loose objects (:mod:`.objects`): a scene with objects runs the
physics engine (:mod:`..physics`), in which the planes and boxes are fixed bodies too.
``[[conveyor]]``, ``[[sensor]]`` and ``[[feeder]]`` tables add a cell's elements tied to the box's
IO (:mod:`.cell`); they run in the same engine.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...model import kinematics as kin
from ...tomlfile import check_keys, load_toml
from ..core.controller_protocol import Controller
from .cell import Cell, parse_cell
from .objects import ObjectSpec, parse_objects


@dataclass(frozen=True)
class Plane:
    """A half-space: the solid lies behind ``point`` along ``-normal`` (unit, base frame)."""

    name: str
    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    stiffness: float  # N/mm
    damping: float = 0.0  # N s/mm
    friction: float = 0.0

    def penetration(self, p: np.ndarray) -> tuple[float, np.ndarray]:
        n = np.asarray(self.normal)
        return float(np.dot(np.asarray(self.point) - p, n)), n


@dataclass(frozen=True)
class Box:
    """An axis-aligned box between corners ``min`` and ``max`` (mm, base frame)."""

    name: str
    min: tuple[float, float, float]
    max: tuple[float, float, float]
    stiffness: float
    damping: float = 0.0
    friction: float = 0.0

    def penetration(self, p: np.ndarray) -> tuple[float, np.ndarray]:
        lo, hi = np.asarray(self.min), np.asarray(self.max)
        if np.any(p <= lo) or np.any(p >= hi):
            return -1.0, np.zeros(3)
        depths = np.concatenate([p - lo, hi - p])  # to the -x,-y,-z faces, then the +x,+y,+z faces
        i = int(np.argmin(depths))
        n = np.zeros(3)
        n[i % 3] = -1.0 if i < 3 else 1.0
        return float(depths[i]), n


Shape = Plane | Box


@dataclass(frozen=True)
class Scene:
    """The shapes of one contact scene, its loose objects (as declared: where they start) and its
    cell elements (conveyors, sensors, feeders)."""

    shapes: tuple[Shape, ...] = ()
    objects: tuple[ObjectSpec, ...] = ()
    cell: Cell = Cell()

    @property
    def physical(self) -> bool:
        """Whether the scene runs the physics engine: it has objects or cell elements."""
        return bool(self.objects or self.cell)

    def to_dict(self) -> dict[str, list[dict[str, Any]]]:
        """The scene as the tables :func:`parse_scene` reads (the admin channel shows it so)."""
        out: dict[str, list[dict[str, Any]]] = {"plane": [], "box": []}
        for s in self.shapes:
            d = dict(vars(s))
            out["plane" if isinstance(s, Plane) else "box"].append(d)
        if self.objects:
            out["object"] = [o.to_dict() for o in self.objects]
        out.update(self.cell.to_dict())
        return out


def vec3(shape: str, key: str, v: Any) -> tuple[float, float, float]:
    if not isinstance(v, Sequence) or isinstance(v, str) or len(v) != 3:
        raise ValueError(f"{shape}: {key} must be a list of three numbers (mm)")
    try:
        x = tuple(float(e) for e in v)
    except (TypeError, ValueError):
        raise ValueError(f"{shape}: {key} must be a list of three numbers (mm)") from None
    if not all(math.isfinite(e) for e in x):
        raise ValueError(f"{shape}: {key} must be finite")
    return (x[0], x[1], x[2])


def _number(shape: str, key: str, v: Any, *, positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise ValueError(f"{shape}: {key} must be a finite number")
    if float(v) < 0 or (positive and float(v) == 0):
        raise ValueError(f"{shape}: {key} must be {'> 0' if positive else '>= 0'}, not {v}")
    return float(v)


_COMMON = {"name", "stiffness", "damping", "friction"}
#: The tables of a scene file, and the keys of each fixed shape (``[[object]]``: objects.KEYS).
TABLES = ("plane", "box", "object", "conveyor", "sensor", "feeder")
SHAPE_KEYS: dict[str, frozenset[str]] = {"plane": frozenset(_COMMON | {"point", "normal"}),
                                         "box": frozenset(_COMMON | {"min", "max"})}


def _shape(kind: str, i: int, t: Any) -> Shape:
    label = f"{kind} {i + 1}"
    if not isinstance(t, Mapping):
        raise ValueError(f"{label}: a table of keys expected")
    label = f"{kind} {t.get('name', i + 1)!s}"
    keys = set(SHAPE_KEYS[kind])
    check_keys(t, sorted(keys), label)
    for need in sorted(keys - {"name", "damping", "friction"}):
        if need not in t:
            raise ValueError(f"{label}: missing {need!r}")
    name = str(t.get("name", f"{kind}{i + 1}"))
    k = _number(label, "stiffness", t["stiffness"], positive=True)
    c = _number(label, "damping", t.get("damping", 0.0))
    mu = _number(label, "friction", t.get("friction", 0.0))
    if kind == "plane":
        n = np.asarray(vec3(label, "normal", t["normal"]))
        norm = float(np.linalg.norm(n))
        if norm < 1e-9:
            raise ValueError(f"{label}: normal must not be zero")
        u = n / norm
        unit = (float(u[0]), float(u[1]), float(u[2]))
        return Plane(name, vec3(label, "point", t["point"]), unit, k, c, mu)
    lo, hi = vec3(label, "min", t["min"]), vec3(label, "max", t["max"])
    if any(a >= b for a, b in zip(lo, hi, strict=True)):
        raise ValueError(f"{label}: min must be below max on every axis")
    return Box(name, lo, hi, k, c, mu)


def parse_scene(tables: Mapping[str, Any]) -> Scene:
    """A :class:`Scene` from TOML-like tables ``{"plane": [...], "box": [...], "object": [...]}``
    (and ``conveyor``, ``sensor``, ``feeder``); ValueError on anything else (one line naming the
    shape and the key)."""
    if not isinstance(tables, Mapping):
        raise ValueError("a scene is a table with 'plane', 'box' and 'object' lists")
    check_keys(tables, TABLES)
    shapes: list[Shape] = []
    for kind in ("plane", "box"):
        items = tables.get(kind, [])
        if not isinstance(items, list):
            raise ValueError(f"{kind} must be a list of tables ([[{kind}]])")
        shapes.extend(_shape(kind, i, t) for i, t in enumerate(items))
    objects = parse_objects(tables.get("object", []))
    cell = parse_cell(tables)
    names = {o.name for o in objects}
    for part in cell.part_names():
        if part in names:
            raise ValueError(f"object {part}: the name is used twice (a feeder's part has it)")
    return Scene(tuple(shapes), objects, cell)


def load_scene(path: str | Path) -> Scene:
    """Read a scene file; ValueError if it cannot be used (one line naming the file, the TOML
    files' one format: xarm_emu.tomlfile)."""
    return load_toml(path, "scene file", parse_scene)


def scene_of(ctl: Controller) -> Scene:
    """The contact scene of ``ctl`` (in its controller state); empty unless one was set."""
    sc = ctl.data.contact_scene
    return sc if isinstance(sc, Scene) else Scene()


def set_scene(ctl: Controller, scene: Scene) -> None:
    """Make ``scene`` the contact scene of ``ctl``."""
    ctl.data.contact_scene = scene


def _tcp_point_velocity(ctl: Controller) -> tuple[np.ndarray, np.ndarray]:
    """The TCP point (mm, base frame) and its velocity (mm/s) from the joints and their rates."""
    model, d = ctl.model, ctl.data
    off = np.asarray(ctl.settings.tcp_offset[:3], dtype=float)
    T = kin.fk(model, d.q)
    p = T[:3, 3] + T[:3, :3] @ off
    J = kin.jacobian(model, d.q)
    v_lin, w = J[:3] @ d.qd, J[3:] @ d.qd
    r = T[:3, :3] @ off
    spin = np.array([w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], w[0] * r[1] - w[1] * r[0]])
    return p, v_lin + spin


def shape_force(shape: Shape, p: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The force (N, base frame) of one shape on a point at ``p`` moving at ``v`` (mm, mm/s)."""
    depth, n = shape.penetration(p)
    if depth <= 0:
        return np.zeros(3)
    rate = -float(np.dot(v, n))  # mm/s deeper
    fn = max(0.0, shape.stiffness * depth + shape.damping * rate)
    f = fn * n
    if shape.friction > 0 and fn > 0:
        vt = v - np.dot(v, n) * n
        speed = float(np.linalg.norm(vt))
        if speed > 1e-6:
            f = f - shape.friction * fn * vt / speed * min(1.0, speed / 1.0)  # smooth below 1 mm/s
    return f


def scene_wrench(ctl: Controller) -> np.ndarray:
    """The wrench (base frame, N and N m about the TCP point) of the scene on the TCP."""
    scene = scene_of(ctl)
    if not scene.shapes:
        return np.zeros(6)
    p, v = _tcp_point_velocity(ctl)
    f = sum((shape_force(s, p, v) for s in scene.shapes), np.zeros(3))
    return np.concatenate([f, np.zeros(3)])

