"""Cell elements of a scene file, tied to the control box's IO: ``[[conveyor]]``, ``[[sensor]]`` and
``[[feeder]]`` tables beside ``[[plane]]``, ``[[box]]`` and ``[[object]]`` (docs/physics.md, "Cells").

Pure data: reading the tables needs no physics engine. IO is named as on the control box and the
tool connector: ``CO0``-``CO15`` and ``TO0``/``TO1`` are digital outputs, ``CI0``-``CI15`` and
``TI0``-``TI4`` digital inputs (the numbers the SDK's ``*_cgpio_*`` and ``*_tgpio_*`` calls take)::

    [[conveyor]]
    name = "belt"
    min = [150, 250, -130]   # mm, base frame: the belt as a box between two corners
    max = [650, 350, -100]   # its top face (max z) carries the parts
    direction = [-1, 0, 0]   # along the top face
    speed = 100              # mm/s
    output = "CO0"           # optional: runs while this output is on; without it, always
    friction = 1.0           # optional

    [[sensor]]
    name = "eye"
    input = "CI0"            # the digital input it drives
    from = [250, 230, -80]   # a photo-eye beam between two points (mm) ...
    to = [250, 370, -80]
    # min = [...]  max = [...]   ... or a presence region (an object's centre inside it)
    delay = 0.01             # optional: s the input lags the beam (switching delay)
    active = 0               # optional: the input's level while interrupted

    [[feeder]]
    name = "part"            # the parts are named part-1, part-2, ...
    shape = "box"            # shape, size, mass, friction, color: as an [[object]]
    size = [40, 40, 40]
    mass = 0.1
    position = [600, 300, -80]   # where each new part is placed (mm), at rest
    rpy = [0, 0, 0]
    count = 3                # how many parts it places in all
    every = 6.0              # one every so many s (the first at ``start``, default 0) ...
    # trigger = "CO1"        # ... or one on each rising edge of an output
    offset = [5, 5, 10]      # optional: each part moved by up to +/- dx, dy mm and dyaw deg ...
    seed = 1                 # ... drawn from this seed (the same parts on every run)

A table with an error raises ``ValueError`` with one line naming the element and the key.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...tomlfile import check_keys
from .objects import ObjectSpec, parse_object

#: The most parts one feeder places (each is a body of the engine from the start).
MAX_FEED = 100
Vec3 = tuple[float, float, float]
_IO = re.compile(r"^(C|T)(I|O)(\d{1,2})$")
#: How many digital IO of each kind a name may give: the control box's 16, the tool's TI0-TI4 /
#: TO0-TO1 (the box checks the number against its own IO when the scene is attached).
_IO_COUNT = {("C", "I"): 16, ("C", "O"): 16, ("T", "I"): 5, ("T", "O"): 2}


@dataclass(frozen=True)
class IoRef:
    """One digital IO: ``kind`` "cgpio" (control box) or "tgpio" (tool), its number, and whether it
    is an input ("I") or an output ("O")."""

    kind: str
    index: int
    direction: str

    @property
    def name(self) -> str:
        """As the scene file writes it: 'CO0', 'TI1'."""
        return ("C" if self.kind == "cgpio" else "T") + self.direction + str(self.index)


def _io(label: str, key: str, v: Any, direction: str) -> IoRef:
    what = "an output such as 'CO0' or 'TO1'" if direction == "O" else "an input such as 'CI0' or 'TI1'"
    m = _IO.match(v.strip().upper()) if isinstance(v, str) else None
    if m is None or m[2] != direction:
        raise ValueError(f"{label}: {key} must be {what}, not {v!r}")
    n = int(m[3])
    if n >= _IO_COUNT[(m[1], m[2])]:
        raise ValueError(f"{label}: {key} {v!r} is no digital IO of the {'box' if m[1] == 'C' else 'tool'}")
    return IoRef("cgpio" if m[1] == "C" else "tgpio", n, direction)


def _vec(label: str, key: str, v: Any) -> tuple[float, float, float]:
    if (not isinstance(v, Sequence) or isinstance(v, str) or len(v) != 3
            or any(isinstance(e, bool) or not isinstance(e, (int, float)) for e in v)
            or not all(math.isfinite(float(e)) for e in v)):
        raise ValueError(f"{label}: {key} must be three finite numbers")
    return (float(v[0]), float(v[1]), float(v[2]))


def _num(label: str, key: str, v: Any, *, low: float = 0.0, positive: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise ValueError(f"{label}: {key} must be a finite number")
    if float(v) < low or (positive and float(v) <= 0):
        raise ValueError(f"{label}: {key} must be {'> 0' if positive else f'>= {low:g}'}, not {v}")
    return float(v)


def _corners(label: str, t: Mapping[str, Any]) -> tuple[Vec3, Vec3]:
    lo, hi = _vec(label, "min", t["min"]), _vec(label, "max", t["max"])
    if any(a >= b for a, b in zip(lo, hi, strict=True)):
        raise ValueError(f"{label}: min must be below max on every axis")
    return lo, hi


def _table(kind: str, i: int, t: Any, keys: frozenset[str], need: Sequence[str]) -> str:
    if not isinstance(t, Mapping):
        raise ValueError(f"{kind} {i + 1}: a table of keys expected")
    label = f"{kind} {t.get('name', i + 1)!s}"
    check_keys(t, sorted(keys), label)
    for k in need:
        if k not in t:
            raise ValueError(f"{label}: missing {k!r}")
    return label


@dataclass(frozen=True)
class ConveyorSpec:
    """A belt: a box whose top face carries what rests on it along ``direction`` at ``speed``."""

    name: str
    min: tuple[float, float, float]
    max: tuple[float, float, float]
    direction: tuple[float, float, float]  # unit, horizontal
    speed: float  # mm/s
    output: IoRef | None = None  # runs while it is on; None: always
    friction: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"name": self.name, "min": list(self.min), "max": list(self.max),
                             "direction": list(self.direction), "speed": self.speed,
                             "friction": self.friction}
        if self.output is not None:
            d["output"] = self.output.name
        return d


@dataclass(frozen=True)
class SensorSpec:
    """A photo-eye beam (``beam``: two points) or a presence region (``region``: two corners)
    driving digital input ``input`` at level ``active`` while an object interrupts it."""

    name: str
    input: IoRef
    beam: tuple[tuple[float, float, float], tuple[float, float, float]] | None
    region: tuple[tuple[float, float, float], tuple[float, float, float]] | None
    delay: float  # s
    active: int  # the input's level while interrupted

    @property
    def idle(self) -> int:
        return 1 - self.active

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"name": self.name, "input": self.input.name,
                             "delay": self.delay, "active": self.active}
        if self.beam is not None:
            d["from"], d["to"] = list(self.beam[0]), list(self.beam[1])
        if self.region is not None:
            d["min"], d["max"] = list(self.region[0]), list(self.region[1])
        return d


@dataclass(frozen=True)
class FeederSpec:
    """Places up to ``count`` parts shaped as ``part`` at its pose: every ``every`` s from ``start``,
    or on each rising edge of output ``trigger``; each moved by a draw within ``offset`` from
    ``seed``."""

    name: str
    part: ObjectSpec  # the shape, mass and pose of each part (its name: the feeder's)
    count: int
    every: float | None
    trigger: IoRef | None
    start: float = 0.0
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)  # mm, mm, deg
    seed: int = 0

    def part_name(self, k: int) -> str:
        """The name of the ``k``-th part (from 0): ``<feeder>-<k + 1>``."""
        return f"{self.name}-{k + 1}"

    def pose(self, k: int) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """Where the ``k``-th part is placed: (position mm, rpy deg), the same for the same seed."""
        p, r = self.part.position, self.part.rpy
        if not any(self.offset):
            return p, r
        u = np.random.default_rng([self.seed & 0xFFFFFFFF, k]).uniform(-1.0, 1.0, 3)
        dx, dy, dyaw = (float(a * b) for a, b in zip(u, self.offset, strict=True))
        return (p[0] + dx, p[1] + dy, p[2]), (r[0], r[1], r[2] + dyaw)

    def to_dict(self) -> dict[str, Any]:
        d = self.part.to_dict()
        d.update(name=self.name, count=self.count, start=self.start, offset=list(self.offset), seed=self.seed)
        if self.every is not None:
            d["every"] = self.every
        if self.trigger is not None:
            d["trigger"] = self.trigger.name
        return d


#: The keys of each cell table (a scene file's [[conveyor]], [[sensor]] and [[feeder]]).
CONVEYOR_KEYS = frozenset({"name", "min", "max", "direction", "speed", "output", "friction"})
SENSOR_KEYS = frozenset({"name", "input", "from", "to", "min", "max", "delay", "active"})
FEEDER_PART_KEYS = frozenset({"shape", "size", "mass", "position", "rpy", "friction", "color"})
FEEDER_KEYS = frozenset({"name", "count", "every", "trigger", "start", "offset", "seed"}) | FEEDER_PART_KEYS
KEYS: dict[str, frozenset[str]] = {"conveyor": CONVEYOR_KEYS, "sensor": SENSOR_KEYS, "feeder": FEEDER_KEYS}


def parse_conveyor(i: int, t: Any) -> ConveyorSpec:
    label = _table("conveyor", i, t, CONVEYOR_KEYS, ("min", "max", "direction", "speed"))
    lo, hi = _corners(label, t)
    d = np.asarray(_vec(label, "direction", t["direction"]))
    if abs(d[2]) > 1e-9 or float(np.hypot(d[0], d[1])) < 1e-9:
        raise ValueError(f"{label}: direction must be horizontal and not zero (along the top face)")
    d = d / float(np.linalg.norm(d))
    out = _io(label, "output", t["output"], "O") if "output" in t else None
    return ConveyorSpec(str(t.get("name", f"conveyor{i + 1}")), lo, hi, (float(d[0]), float(d[1]), 0.0),
                        _num(label, "speed", t["speed"]), out,
                        _num(label, "friction", t.get("friction", 1.0)))


def parse_sensor(i: int, t: Any) -> SensorSpec:
    label = _table("sensor", i, t, SENSOR_KEYS, ("input",))
    beam = region = None
    if "from" in t or "to" in t:
        if "min" in t or "max" in t:
            raise ValueError(f"{label}: a beam (from, to) or a region (min, max), not both")
        if "from" not in t or "to" not in t:
            raise ValueError(f"{label}: a beam needs both 'from' and 'to'")
        a, b = _vec(label, "from", t["from"]), _vec(label, "to", t["to"])
        if a == b:
            raise ValueError(f"{label}: the beam's two points must differ")
        beam = (a, b)
    elif "min" in t and "max" in t:
        region = _corners(label, t)
    else:
        raise ValueError(f"{label}: give a beam (from, to) or a region (min, max)")
    io = _io(label, "input", t["input"], "I")
    active = t.get("active", 0 if io.kind == "cgpio" else 1)
    if active not in (0, 1) or isinstance(active, bool):
        raise ValueError(f"{label}: active must be 0 or 1")
    return SensorSpec(str(t.get("name", f"sensor{i + 1}")), io, beam, region,
                      _num(label, "delay", t.get("delay", 0.0)), int(active))


def parse_feeder(i: int, t: Any) -> FeederSpec:
    label = _table("feeder", i, t, FEEDER_KEYS, ("count",))
    name = str(t.get("name", f"feeder{i + 1}"))
    part = parse_object(i, {"name": name, **{k: v for k, v in t.items() if k in FEEDER_PART_KEYS}})
    count = t["count"]
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_FEED:
        raise ValueError(f"{label}: count must be a whole number from 1 to {MAX_FEED}")
    if ("every" in t) == ("trigger" in t):
        raise ValueError(f"{label}: give 'every' (s) or 'trigger' (an output), one of them")
    every = _num(label, "every", t["every"], positive=True) if "every" in t else None
    trigger = _io(label, "trigger", t["trigger"], "O") if "trigger" in t else None
    offset = _vec(label, "offset", t.get("offset", (0, 0, 0)))
    if min(offset) < 0:
        raise ValueError(f"{label}: offset must be >= 0 (the most each part is moved either way)")
    seed = t.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ValueError(f"{label}: seed must be a whole number")
    return FeederSpec(name, part, int(count), every, trigger, _num(label, "start", t.get("start", 0.0)),
                      offset, int(seed))


def _parse_list(kind: str, items: Any, parse: Any) -> tuple[Any, ...]:
    if not isinstance(items, list):
        raise ValueError(f"{kind} must be a list of tables ([[{kind}]])")
    out = tuple(parse(i, t) for i, t in enumerate(items))
    seen: set[str] = set()
    for e in out:
        if e.name in seen:
            raise ValueError(f"{kind} {e.name}: the name is used twice")
        seen.add(e.name)
    return out


@dataclass(frozen=True)
class Cell:
    """The cell elements of a scene."""

    conveyors: tuple[ConveyorSpec, ...] = ()
    sensors: tuple[SensorSpec, ...] = ()
    feeders: tuple[FeederSpec, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.conveyors or self.sensors or self.feeders)

    def part_names(self) -> list[str]:
        return [f.part_name(k) for f in self.feeders for k in range(f.count)]

    def to_dict(self) -> dict[str, list[dict[str, Any]]]:
        out: dict[str, list[dict[str, Any]]] = {}
        for key, items in (("conveyor", self.conveyors), ("sensor", self.sensors), ("feeder", self.feeders)):
            if items:
                out[key] = [e.to_dict() for e in items]
        return out


def parse_cell(tables: Mapping[str, Any]) -> Cell:
    """The ``[[conveyor]]``, ``[[sensor]]`` and ``[[feeder]]`` lists of a scene's tables."""
    return Cell(_parse_list("conveyor", tables.get("conveyor", []), parse_conveyor),
                _parse_list("sensor", tables.get("sensor", []), parse_sensor),
                _parse_list("feeder", tables.get("feeder", []), parse_feeder))
