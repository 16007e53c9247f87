"""The cell elements of a scene (controller/scene/cell.py) in the physics world, tied to the box's IO.

Each control period, before the world steps: a conveyor runs while its output is on (or always),
its belt's surface moving at its speed; a feeder due (its time reached, or its output's rising edge
seen) places its next part. After the step: each sensor looks whether an object interrupts its beam
(a ray of the engine that sees only objects) or has its centre in its region, and drives its input
to its active level once the beam has stayed so for its delay, to its idle level likewise. All of it
reads controller time and the world's own state, so it is the same on every run of the stepped
clock, and :class:`CellState` (inside :class:`~.world.PhysicsState`) is what a checkpoint carries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from ..core.interface import NOT_IDLE
from ..scene.cell import IoRef
from .mjcf import MM

if TYPE_CHECKING:
    from ..core.controller_protocol import Controller
    from ..scene.contact import Scene


@dataclass(slots=True)
class CellState:
    """Every mutable value of a scene's cell elements, in the scene's order of each kind."""

    #: Parts each feeder has placed.
    fed: list[int] = field(default_factory=list)
    #: Each feeder's trigger output level at the last period (its rising edge places a part).
    trigger: list[int] = field(default_factory=list)
    #: Each sensor: interrupted now, interrupted as its input says, time the beam last changed (s).
    beam: list[bool] = field(default_factory=list)
    level: list[bool] = field(default_factory=list)
    since: list[float] = field(default_factory=list)
    #: Each conveyor running.
    running: list[bool] = field(default_factory=list)


def fresh_cell(scene: Scene) -> CellState:
    """The power-on state of ``scene``'s cell: nothing placed, no beam interrupted, belts still."""
    c = scene.cell
    return CellState([0] * len(c.feeders), [0] * len(c.feeders), [False] * len(c.sensors),
                     [False] * len(c.sensors), [0.0] * len(c.sensors), [False] * len(c.conveyors))


def _outputs(io: Any) -> tuple[int, int]:
    """The output words of the control box and the tool (bit n: output n)."""
    if io is None:
        return 0, 0
    return int(io.cgpio.digital_outputs), int(io.tool.digital_outputs)


def _level(words: tuple[int, int], ref: IoRef) -> int:
    return (words[0 if ref.kind == "cgpio" else 1] >> ref.index) & 1


class CellRunner:
    """Steps the cell elements of ``world``'s scene (a :class:`~.world.World`) with the IO module
    ``io`` of the box."""

    def __init__(self, world: Any, io: Any) -> None:
        self.world = world
        self.io = io
        self.cell = world.scene.cell
        self._geomid = np.zeros(1, dtype=np.int32)  # mj_ray's output: the geom hit
        #: The world's change count when the sensors last looked (the objects stand still between).
        self._looked = -1
        if io is not None:
            refs = [(f"sensor {s.name}", s.input) for s in self.cell.sensors]
            refs += [(f"conveyor {c.name}", c.output) for c in self.cell.conveyors]
            refs += [(f"feeder {f.name}", f.trigger) for f in self.cell.feeders]
            for label, ref in refs:
                if ref is not None:
                    self._check(io, label, ref)

    @staticmethod
    def _check(io: Any, label: str, ref: IoRef) -> None:
        """ValueError (one line) unless the box has the IO ``ref`` names."""
        try:
            if ref.direction == "I":
                io.check_input(ref.kind, ref.index)
            elif ref.kind == "cgpio":
                io.cgpio._check_index(ref.index)
        except Exception as exc:  # the IO module's refusal (a warning-12 parameter error)
            raise ValueError(f"{label}: {ref.name} is no IO of this box ({exc})") from None

    @property
    def state(self) -> CellState:
        cell: CellState = self.world.state.cell
        return cell

    def before(self, ctl: Controller) -> None:
        """Belts and feeders, before the world steps this period."""
        st, now = self.state, ctl.time
        words = _outputs(self.io)
        for i, c in enumerate(self.cell.conveyors):
            st.running[i] = c.output is None or bool(_level(words, c.output))
        for i, f in enumerate(self.cell.feeders):
            if f.trigger is not None:
                level = _level(words, f.trigger)
                due = level and not st.trigger[i]
                st.trigger[i] = level
            else:
                assert f.every is not None
                due = now + 1e-9 >= f.start + st.fed[i] * f.every
            if due and st.fed[i] < f.count:
                pos, rpy = f.pose(st.fed[i])
                self.world.feed(i, pos, rpy)

    def after(self, ctl: Controller) -> None:
        """Sensors, after the world stepped this period: their inputs follow after their delay."""
        st, now = self.state, ctl.time
        version = self.world._version
        looked, self._looked = self._looked == version, version
        for i, s in enumerate(self.cell.sensors):
            hit = st.beam[i] if looked else self._interrupted(s)
            if hit != st.beam[i]:
                st.beam[i], st.since[i] = hit, now
            if st.level[i] != hit and now + 1e-9 >= st.since[i] + s.delay:
                st.level[i] = hit
            if self.io is not None:
                level = s.active if st.level[i] else s.idle
                if self.io_level(s.input) != level:
                    self.io.set_input(s.input.kind, s.input.index, level)

    def io_level(self, ref: IoRef) -> int:
        io = self.io
        if ref.kind == "cgpio":
            return int((io.cgpio.digital_inputs >> ref.index) & 1)
        return int(io.tool.input(ref.index))

    def _interrupted(self, s: Any) -> bool:
        w = self.world
        d = w.d
        if s.beam is not None:
            a = np.asarray(s.beam[0], dtype=float) * MM
            vec = (np.asarray(s.beam[1], dtype=float) - s.beam[0]) * MM
            x = mujoco.mj_ray(w.m, d, a, vec, w.ray_groups, 1, -1, self._geomid)
            return 0.0 <= x <= 1.0
        lo, hi = s.region
        for i in w.listed():
            _, adr, _, _ = w.objects[i]
            p = d.qpos[adr: adr + 3] / MM
            if all(lo[k] <= p[k] <= hi[k] for k in range(3)):
                return True
        return False

    def idle_until(self, ctl: Controller) -> float:
        """Controller time up to which the cell changes nothing: a sensor waiting out its delay or an
        output a belt or a feeder follows changed: not idle; a timed feeder: its next part's time."""
        st = self.state
        if st.level != st.beam:
            return NOT_IDLE
        words = _outputs(self.io)
        for i, c in enumerate(self.cell.conveyors):
            if c.output is not None and bool(_level(words, c.output)) != st.running[i]:
                return NOT_IDLE
        until = math.inf
        for i, f in enumerate(self.cell.feeders):
            if f.trigger is not None:
                if _level(words, f.trigger) != st.trigger[i] and st.fed[i] < f.count:
                    return NOT_IDLE
            elif st.fed[i] < f.count:
                assert f.every is not None
                until = min(until, f.start + st.fed[i] * f.every)
        return until

    def status(self) -> dict[str, list[dict[str, Any]]]:
        """Every element with its state, for ``xarm-emu scene --json``."""
        st = self.state
        out: dict[str, list[dict[str, Any]]] = {}
        out["conveyors"] = [{"name": c.name, "running": st.running[i], "speed": c.speed,
                             "output": None if c.output is None else c.output.name}
                            for i, c in enumerate(self.cell.conveyors)]
        out["sensors"] = [{"name": s.name, "input": s.input.name, "interrupted": st.level[i],
                           "level": s.active if st.level[i] else s.idle}
                          for i, s in enumerate(self.cell.sensors)]
        out["feeders"] = [{"name": f.name, "count": st.fed[i], "of": f.count}
                          for i, f in enumerate(self.cell.feeders)]
        return out
