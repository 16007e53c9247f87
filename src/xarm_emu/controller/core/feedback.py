"""Feedback events (registers 253/254, ``FirmwareProfile.feedback``), pure and deterministic.

The controller never touches a socket: :class:`FeedbackQueue` records, per connection, the mask
register 254 set, tags each task queued by a request with the origin of that request (connection,
transaction id, protocol id and the mask current when the task arrived: a later 254 does not
change what an earlier task reports), and watches the command buffer after every control period.
What it sees becomes :class:`FeedbackEvent` values in a queue that the server drains after each
command and each batch of control periods and turns into 21-byte 0xFF frames
(:mod:`xarm_emu.protocol.feedback`) on the connection that sent the command.

- A queued motion task (joint, line, circle moves, pauses): MOTION_START when it starts executing,
  MOTION_FINISH when it ends; a move that starts and ends within one control period (too short to
  plan) and a task discarded before it started (stop, error) finish with code 2, "discarded".
- A queued non-motion task: TRIGGER when it runs. Register 36 (the payload) joins the buffer behind
  the moves queued before it and is triggered when it runs; with nothing queued or moving it runs,
  and is triggered, at once.
- A request that would have queued a task but was refused (warning, error, not ready): MOTION_FINISH
  with code 2 at once, so that no wait on it is left open.
- Register 253: MOTION_FINISH with 253's own transaction id once every task queued before it has
  finished (at once when the buffer is empty).
- Trajectory tasks (registers 61-65) report OTHER_START/OTHER_FINISH through :meth:`FeedbackQueue.emit`
  with the origin they took from :meth:`FeedbackQueue.capture` when they were accepted.

The queue is a controller component (:class:`~xarm_emu.controller.core.interface.Component`): its ``step``
runs at the end of every control period. :func:`feedback_queue` finds or attaches it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from ...protocol.feedback import Feedback, FeedbackCode, FeedbackType
from ...protocol.frame import PROTOCOL_PRIVATE_V3, STATE_FAILED, STATE_NOT_READY
from ...protocol.registers import Flag
from .commands import CircleMove, Dwell, JointMove, LineMove
from .controller_protocol import Controller
from .controller_state import holds
from .interface import NOT_IDLE

#: Queued task classes that move the arm (MOTION_START/MOTION_FINISH); any other queued task is a
#: non-motion task (TRIGGER).
MOTION_TASKS = (JointMove, LineMove, CircleMove, Dwell)
#: Registers whose task, when it ran at once (nothing queued before it), is reported as TRIGGER
#: when it is accepted: the SDK waits for the TRIGGER of register 36 in ``set_tcp_load(wait=True)``.
TRIGGER_REGISTERS = frozenset({36})
#: Registers whose queued tasks are the box's own sequence, not the client's moves (204, load
#: identification: the client waits for its reply): no task frames.
OWN_TASK_REGISTERS = frozenset({204})
#: Register 253 (feedback check).
FEEDBACK_CHECK = 253
#: Mask bits a queued task can report (the rest are reported through :meth:`FeedbackQueue.emit`).
_TASK_BITS = FeedbackType.MOTION_START | FeedbackType.MOTION_FINISH | FeedbackType.TRIGGER
#: Largest number of undrained events kept; older ones are dropped (and counted) beyond it, so a
#: controller nobody drains stays bounded.
MAX_EVENTS = 4096


@dataclass(frozen=True, slots=True)
class Origin:
    """Who asked for a task: the connection, the request's transaction id and protocol id, and the
    connection's register-254 mask when the request arrived."""

    client: int
    tid: int
    protocol: int = PROTOCOL_PRIVATE_V3
    mask: int = 0

    def wants(self, kind: FeedbackType) -> bool:
        return bool(self.mask & kind)


@dataclass(frozen=True, slots=True)
class FeedbackEvent:
    """One feedback frame due on connection ``client``."""

    client: int
    feedback: Feedback

    def encode(self) -> bytes:
        """The 21-byte 0xFF frame."""
        return self.feedback.encode()


@dataclass(slots=True)
class _Task:
    """A queued task being watched."""

    cmd: Any
    origin: Origin
    register: int
    task_id: int
    started: bool = False


@dataclass(slots=True)
class _Check:
    """A register-253 check: done once ``last`` (the last task queued before it) is gone."""

    origin: Origin
    last: Any
    task_id: int


@dataclass(slots=True)
class FeedbackState:
    """Every mutable value of the feedback queue (power-on values: :class:`FeedbackQueue`)."""

    masks: dict[int, int] = field(default_factory=dict)
    _origin: tuple[int, int, int] | None = None
    _register: int = 0
    _codes_before: tuple[int, int] = (0, 0)
    _last_before: Any = None
    _tasks: list[_Task] = field(default_factory=list)
    _checks: list[_Check] = field(default_factory=list)
    _events: deque[FeedbackEvent] = field(default_factory=deque)
    _task_id: int = 0
    _seen: tuple[int, int, int] = (0, 0, 0)
    dropped: int = 0


@holds(FeedbackState)
class FeedbackQueue:
    """Per-connection masks, the watched tasks and the events not yet drained (module docstring)."""

    def __init__(self) -> None:
        self.data = FeedbackState()
        #: connection -> register-254 mask (0 until the connection sets one)
        self.masks: dict[int, int] = {}
        self._origin: tuple[int, int, int] | None = None  # (client, tid, protocol) of the request
        self._register = 0
        self._codes_before = (0, 0)
        self._last_before: Any = None
        self._tasks: list[_Task] = []
        self._checks: list[_Check] = []
        self._events: deque[FeedbackEvent] = deque()
        self._task_id = 0
        self._seen: tuple[int, int, int] = (0, 0, 0)  # buffer length, id(current), merged
        #: Events dropped because nobody drained them (beyond :data:`MAX_EVENTS`).
        self.dropped = 0

    # -- the component interface ---------------------------------------------------------------
    def step(self, dt: float, ctl: Controller) -> None:
        """After each control period: report tasks that started or finished."""
        if self._tasks or self._checks:
            self._observe(ctl)

    def idle_until(self, ctl: Controller) -> float:
        """Idle (:func:`~.interface.idle_until`) while no watched task can have started or finished: the
        buffer, the running command and its chain are as the last look saw them."""
        if self._tasks or self._checks:
            ex = ctl.executor
            if (len(ex.buffer), id(ex.current), ex.data.merged) != self._seen:
                return NOT_IDLE
        return math.inf

    # -- requests -------------------------------------------------------------------------------
    def begin(self, ctl: Controller, client: int, tid: int, protocol: int, register: int) -> None:
        """A request from ``client`` is about to be handled."""
        self._origin = (client, tid, protocol)
        self._register = register
        self._codes_before = (ctl.error_code, ctl.warning_code)
        buf = ctl.executor.buffer
        self._last_before = buf[-1] if buf else None

    def end(self, ctl: Controller, status: int = 0) -> None:
        """The request of :meth:`begin` was handled (reply state byte ``status``): tag the tasks it
        queued, and trigger the immediate tasks the SDK waits for."""
        if self._origin is None:
            return
        origin = self.capture()
        self._origin = None
        if origin is None or not origin.mask & _TASK_BITS or self._register in OWN_TASK_REGISTERS:
            return
        ex = ctl.executor
        new: list[Any] = []
        for cmd in reversed(ex.buffer):
            if cmd is self._last_before:
                break
            new.append(cmd)
        for cmd in reversed(new):
            self._task_id = (self._task_id + 1) & 0xFFFF
            self._tasks.append(_Task(cmd, origin, self._register, self._task_id))
        if new:
            self._seen = (-1, 0, 0)  # look at the buffer after the next period
        elif self._register in TRIGGER_REGISTERS and self._accepted(ctl):
            self.emit(origin, FeedbackType.TRIGGER, self._register, ctl.time, state=status)
        elif self._refused_task(ctl, status):
            # nothing was queued: the task the SDK waits for is over before it began
            self.emit(origin, FeedbackType.MOTION_FINISH, self._register, ctl.time,
                      code=FeedbackCode.DISCARDED, state=status)

    def _refused_task(self, ctl: Controller, status: int) -> bool:
        """Whether the request just handled would have queued a task but was refused (a new error
        or warning, or the reply's not-ready or failed bit)."""
        reg = ctl.registers.get(self._register)
        if reg is None or not reg.flags & Flag.QUEUED:
            return False
        return bool(status & (STATE_NOT_READY | STATE_FAILED)) or not self._accepted(ctl)

    def _accepted(self, ctl: Controller) -> bool:
        """Whether the request just handled was accepted: it raised no new error or warning (a
        warning already set before it stays in the reply's state byte)."""
        error, warning = self._codes_before
        return ctl.error_code in (0, error) and ctl.warning_code in (0, warning)

    def capture(self) -> Origin | None:
        """The origin of the request being handled, with its connection's mask (``None`` outside a
        request from a connection)."""
        if self._origin is None:
            return None
        client, tid, protocol = self._origin
        return Origin(client, tid, protocol, self.masks.get(client, 0))

    def set_mask(self, mask: int) -> bool:
        """Register 254: the mask of the requesting connection; ``False`` outside a connection."""
        if self._origin is None:
            return False
        self.masks[self._origin[0]] = mask & 0xFF
        return True

    def check(self, ctl: Controller) -> None:
        """Register 253: a MOTION_FINISH frame once every earlier task has finished."""
        origin = self.capture()
        if origin is None or not origin.wants(FeedbackType.MOTION_FINISH):
            return
        ex = ctl.executor
        last = ex.buffer[-1] if ex.buffer else ex.current
        self._task_id = (self._task_id + 1) & 0xFFFF
        if last is None:
            self.emit(origin, FeedbackType.MOTION_FINISH, FEEDBACK_CHECK, ctl.time, task_id=self._task_id,
                      state=ctl.status_byte())
            return
        self._checks.append(_Check(origin, last, self._task_id))
        self._seen = (-1, 0, 0)

    def forget(self, client: int) -> None:
        """Connection ``client`` closed: its mask and its pending tasks' reports go."""
        self.masks.pop(client, None)
        self._tasks = [t for t in self._tasks if t.origin.client != client]
        self._checks = [c for c in self._checks if c.origin.client != client]

    # -- events ---------------------------------------------------------------------------------
    def emit(self, origin: Origin | None, kind: FeedbackType, register: int, time_s: float, *,
             code: FeedbackCode = FeedbackCode.SUCCESS, task_id: int | None = None, state: int = 0) -> bool:
        """Queue one event for ``origin`` if its mask asks for ``kind``; returns whether it did.
        ``time_s`` is controller time (the frame carries it in microseconds)."""
        if origin is None or not origin.wants(kind):
            return False
        if task_id is None:
            self._task_id = (self._task_id + 1) & 0xFFFF
            task_id = self._task_id
        if len(self._events) >= MAX_EVENTS:
            self._events.popleft()
            self.dropped += 1
        fb = Feedback(origin.tid, kind, register, task_id, code, int(round(time_s * 1e6)), origin.protocol,
                      state & 0xFF)
        self._events.append(FeedbackEvent(origin.client, fb))
        return True

    def start_other(self, origin: Origin | None, register: int, time_s: float, state: int = 0) -> bool:
        """OTHER_START of a trajectory task (registers 61-65) accepted with ``origin``."""
        return self.emit(origin, FeedbackType.OTHER_START, register, time_s, state=state)

    def finish_other(self, origin: Origin | None, register: int, time_s: float, *, ok: bool = True,
                     state: int = 0) -> bool:
        """OTHER_FINISH of a trajectory task: code 0, or 1 when it failed (the SDK's wait then
        returns its trajectory read/write or playback failure)."""
        code = FeedbackCode.SUCCESS if ok else FeedbackCode.FAILURE
        return self.emit(origin, FeedbackType.OTHER_FINISH, register, time_s, code=code, state=state)

    def drain(self) -> list[FeedbackEvent]:
        """Every event not yet drained, oldest first (the queue is empty afterwards)."""
        out = list(self._events)
        self._events.clear()
        return out

    @property
    def pending(self) -> int:
        """Events not yet drained."""
        return len(self._events)

    # -- watching the buffer --------------------------------------------------------------------
    def _observe(self, ctl: Controller) -> None:
        ex = ctl.executor
        current = ex.current
        seen = (len(ex.buffer), id(current), ex.data.merged)
        if seen == self._seen:
            return  # nothing started, finished or was discarded during this period
        self._seen = seen
        queued = {id(c) for c in ex.buffer}
        now = ctl.time
        state = ctl.status_byte()
        # A task that left the buffer while a blended chain runs (merged) is part of that chain.
        chained = current is not None and ex.data.merged > 0 and not ex.stopping
        keep: list[_Task] = []
        for task in self._tasks:
            cmd = task.cmd
            motion = isinstance(cmd, MOTION_TASKS)
            if id(cmd) in queued:
                keep.append(task)
                continue
            if cmd is current or chained:
                if not task.started:
                    task.started = True
                    kind = FeedbackType.MOTION_START if motion else FeedbackType.TRIGGER
                    self.emit(task.origin, kind, task.register, now, task_id=task.task_id, state=state)
                keep.append(task)
                continue
            if not motion:
                if not task.started:  # ran within one period
                    self.emit(task.origin, FeedbackType.TRIGGER, task.register, now, task_id=task.task_id,
                              state=state)
                continue
            # Gone. Never seen running: it started and ended within one period (too short to plan)
            # or was discarded before it ran (stop, error): code 2.
            code = FeedbackCode.SUCCESS if task.started else FeedbackCode.DISCARDED
            self.emit(task.origin, FeedbackType.MOTION_FINISH, task.register, now, code=code,
                      task_id=task.task_id, state=state)
        self._tasks = keep
        if self._checks:
            left: list[_Check] = []
            for chk in self._checks:
                if id(chk.last) in queued or chk.last is current or chained:
                    left.append(chk)
                else:
                    self.emit(chk.origin, FeedbackType.MOTION_FINISH, FEEDBACK_CHECK, now,
                              task_id=chk.task_id, state=state)
            self._checks = left


def feedback_queue(ctl: Controller) -> FeedbackQueue:
    """The feedback queue of controller ``ctl``, attached as a component on first use."""
    for c in ctl.components:
        if isinstance(c, FeedbackQueue):
            return c
    fq = FeedbackQueue()
    ctl.add_component(fq)
    return fq


def find_feedback_queue(ctl: Controller) -> FeedbackQueue | None:
    """The feedback queue of ``ctl`` if one is attached (no side effect)."""
    for c in ctl.components:
        if isinstance(c, FeedbackQueue):
            return c
    return None
