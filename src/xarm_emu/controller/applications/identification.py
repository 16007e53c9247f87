"""Load identification as a motion (register 204, types 0 and 1; the SDK's ``ft_sensor_iden_load``
and ``iden_tcp_load``).

The box identifies a load by turning the wrist through a sequence of orientations and reading, at
each, what the load does: the F/T sensor's wrench (type 0) or the joint torques (type 1). The
emulator queues that sequence as ordinary joint moves (register 204 as their origin) with a reading
between them: from the present joints to each pose of the F/T sensor's ``iden_poses``
(devices/ft_sensor.py; J5 and J6 turned, clipped to the joint limits), a reading there, and back to
where the arm began. The moves run at :data:`IDEN_SPEED` and :data:`IDEN_ACC`, a wrist's pace in
normal use, so the whole sequence takes about 19 s of controller time on an xArm 6 (15 s on an
xArm 5, 17 s on an xArm 7; ``tests/test_identification.py`` checks the range).
The vendor's material gives no duration; the SDK waits up to 300 s for type 1 and 500 s for type 0,
which this stays well inside.

The rich report's identification progress byte (481) climbs from 0 with each reading and is 100
once the result is in; it stays there until the next identification. The result comes only from
the readings the sequence took (the sensor's ``solve_ft_load``, ``solve_tcp_load``).
The reply waits for the end of the sequence (the server holds it, :func:`finished`); a stop, an
error or anything else that empties the command buffer interrupts it as it would a move, and the
reply then carries the state byte of that moment and zeros.

The mutable values are one :class:`Identification` per controller, kept beside its state.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol, cast

import numpy as np

from ..core.commands import JointMove, Task
from ..core.controller_protocol import Controller

REGISTER = 204
#: Joint speed (rad/s, about 57 deg/s) and acceleration (rad/s^2) of the sequence's moves.
IDEN_SPEED = 1.0
IDEN_ACC = 5.0
TYPE_SENSOR, TYPE_TORQUES = 0, 1


@dataclass
class Identification:
    """One identification: its type, the readings taken so far, the progress byte and the result."""

    kind: int = TYPE_TORQUES
    readings: int = 0  # how many the sequence takes
    samples: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    progress: int = 0
    result: tuple[float, ...] | None = None
    running: bool = False


Samples = list[tuple[np.ndarray, np.ndarray]]


class LoadReadings(Protocol):
    """Where the sequence reads and how it solves: the F/T sensor's functions (its readings for type
    0, the dynamic model's joint torques for type 1), which register 204's handler hands in."""

    def iden_poses(self, ctl: Controller, q0: np.ndarray) -> list[np.ndarray]: ...

    def iden_reading(self, ctl: Controller, index: int, q: np.ndarray | None = None) -> np.ndarray: ...

    def iden_torques(self, ctl: Controller, q: np.ndarray | None = None) -> np.ndarray: ...

    def solve_ft_load(self, ctl: Controller, samples: Samples) -> tuple[float, ...]: ...

    def solve_tcp_load(self, ctl: Controller, samples: Samples) -> tuple[float, ...]: ...


def of(ctl: Controller) -> Identification | None:
    """The controller's last identification, if any."""
    return cast("Identification | None", ctl.data.identification)


def progress(ctl: Controller) -> int:
    """The identification progress (%, rich report byte 481)."""
    iden = of(ctl)
    return 0 if iden is None else iden.progress


def start(ctl: Controller, kind: int, loads: LoadReadings) -> None:
    """Queue the sequence of type ``kind`` from the present joints, reading and solving with
    ``loads`` (the caller has checked that the arm may move)."""
    q0 = np.array(ctl.q, dtype=float)
    lo, hi = ctl.model.lower, ctl.model.upper
    poses = [np.clip(q, lo, hi) for q in loads.iden_poses(ctl, q0)]
    iden = Identification(kind=kind, readings=len(poses), running=True)
    ctl.data.identification = iden
    for i, q in enumerate(poses):
        ctl.queue(JointMove(REGISTER, q, IDEN_SPEED, IDEN_ACC))
        read = functools.partial(_read, ctl, iden, i, loads.iden_reading, loads.iden_torques)
        ctl.queue(Task(REGISTER, read))
    ctl.queue(JointMove(REGISTER, q0, IDEN_SPEED, IDEN_ACC))
    ctl.queue(Task(REGISTER, functools.partial(_finish, ctl, iden, loads.solve_ft_load,
                                               loads.solve_tcp_load)))


def _read(ctl: Controller, iden: Identification, index: int, sensor: Callable[..., np.ndarray],
          torques: Callable[..., np.ndarray]) -> None:
    q = np.array(ctl.q, dtype=float)
    reading = sensor(ctl, index, q) if iden.kind == TYPE_SENSOR else torques(ctl, q)
    iden.samples.append((q, reading))
    iden.progress = min(99, round(100 * len(iden.samples) / (iden.readings + 1)))


def _finish(ctl: Controller, iden: Identification, solve_ft: Callable[..., tuple[float, ...]],
            solve_tcp: Callable[..., tuple[float, ...]]) -> None:
    if iden.kind == TYPE_SENSOR:
        iden.result = solve_ft(ctl, iden.samples)
    else:
        iden.result = solve_tcp(ctl, iden.samples)
    iden.progress = 100
    iden.running = False


def finished(ctl: Controller) -> bool:
    """Whether the identification the last register 204 started is over: its result is in, or the
    command buffer no longer holds its moves (a stop or an error discarded them)."""
    iden = of(ctl)
    if iden is None or not iden.running:
        return True
    if iden.result is None and not ctl.executor.active:
        iden.running = False  # interrupted
        return True
    return False


def reply(ctl: Controller) -> dict[str, Any]:
    """Register 204's reply values once :func:`finished`: the result, or zeros when interrupted."""
    iden = of(ctl)
    r = iden.result if iden is not None and iden.result is not None else None
    if iden is not None and iden.kind == TYPE_SENSOR:
        vals = r if r is not None else (0.0,) * 10
        return {"load": tuple(vals[:4]), "offsets": tuple(vals[4:10])}
    vals = r if r is not None else (0.0,) * 4
    return {"load": tuple(vals[:4])}
